// read_cloud on a fuzzed .ply cloud (ascii, binary little and big endian; seeds with normals and
// colours). Asserts the reader's contract (cloud_checks.hpp) and a write/read round trip.
#include "cloud_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("in.ply", data, size);
    fuzz::run([&] {
        CloudReadReport report;
        const PointCloud cloud = read_cloud(path, &report);
        fuzz::check_read_cloud(cloud, report);
        fuzz::check_round_trip(cloud, "out.ply", size % 2 ? CloudEncoding::ascii : CloudEncoding::binary);
    });
    return 0;
}
