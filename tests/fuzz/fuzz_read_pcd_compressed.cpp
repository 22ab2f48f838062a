// binary_compressed PCD data behind a valid header: the target writes the header (point count and
// fields from the first bytes) and the rest of the input is the data section, compressed and
// uncompressed sizes included, so the fuzzer spends its time in the LZF decoder and the size
// checks instead of in the header. Asserts the reader's contract (cloud_checks.hpp).
#include <string>

#include "cloud_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    fuzz::Bytes bytes(data, size);
    const int width = bytes.in(1, 512);
    const int height = bytes.in(0, 3) == 0 ? 2 : 1;
    const char* layouts[][4] = {
        {"x y z", "4 4 4", "F F F", "1 1 1"},
        {"x y z rgb", "4 4 4 4", "F F F U", "1 1 1 1"},
        {"x y z normal_x normal_y normal_z curvature", "4 4 4 4 4 4 4", "F F F F F F F", "1 1 1 1 1 1 1"},
        {"x y z _", "4 4 4 1", "F F F U", "1 1 1 4"},
    };
    const auto& layout = layouts[bytes.byte() % 4];
    const std::string header = std::string("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS ") + layout[0] +
                               "\nSIZE " + layout[1] + "\nTYPE " + layout[2] + "\nCOUNT " + layout[3] +
                               "\nWIDTH " + std::to_string(width) + "\nHEIGHT " + std::to_string(height) +
                               "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(width * height) +
                               "\nDATA binary_compressed\n";
    const std::size_t used = size - bytes.left();
    std::string file = header;
    file.append(reinterpret_cast<const char*>(data) + used, size - used);
    const auto path = fuzz::write_input("in.pcd", file.data(), file.size());
    fuzz::run([&] {
        CloudReadReport report;
        const PointCloud cloud = read_cloud(path, &report);
        fuzz::check_read_cloud(cloud, report);
        fuzz::check(report.points_in == std::size_t(width) * std::size_t(height), "points_in is not width x height");
    });
    return 0;
}
