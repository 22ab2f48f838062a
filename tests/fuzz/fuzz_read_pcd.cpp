// read_cloud on a fuzzed .pcd file, any encoding (the seeds hold ascii, binary and
// binary_compressed, with and without normals, colours and organization). Asserts the reader's
// contract (cloud_checks.hpp) and that what it accepts writes and reads back unchanged, in an
// encoding picked by the input's size.
#include "cloud_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("in.pcd", data, size);
    fuzz::run([&] {
        CloudReadReport report;
        const PointCloud cloud = read_cloud(path, &report);
        fuzz::check_read_cloud(cloud, report);
        const CloudEncoding encodings[] = {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed};
        fuzz::check_round_trip(cloud, "out.pcd", encodings[size % 3]);
    });
    return 0;
}
