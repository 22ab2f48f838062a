#include "mfpc/core/cloud_io.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "cloud_format.hpp"
#include "mfpc/core/atomic_file.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

enum class CloudFormat { pcd, ply };

CloudFormat format_of(const std::filesystem::path& path)
{
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension == ".pcd") return CloudFormat::pcd;
    if (extension == ".ply") return CloudFormat::ply;
    if (extension.empty()) throw Error(path.string(), "no file extension (expected .pcd or .ply)");
    throw Error(path.string(), "unknown extension " + detail::quoted(path.extension().string()) +
                                   " (expected .pcd or .ply)");
}

// The whole file: both formats are parsed from memory, so reading never depends on stream state
// and every bound can be checked against the real size before anything is allocated for points.
std::vector<std::uint8_t> read_whole_file(const std::filesystem::path& path, const std::string& where)
{
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (!std::filesystem::exists(status)) throw Error(where, "no such file");
    if (std::filesystem::is_directory(status)) throw Error(where, "is a directory, not a cloud file");
    // A FIFO or device could block forever or never end.
    if (!std::filesystem::is_regular_file(status)) throw Error(where, "not a regular file");
    const std::uintmax_t size = std::filesystem::file_size(path, error);
    if (error) throw Error(where, "cannot read its size: " + error.message());
    if (size == 0) throw Error(where, "file is empty");

    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(where, std::string("cannot open for reading: ") + std::strerror(errno));
    std::vector<std::uint8_t> bytes(size);
    in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
    if (static_cast<std::uintmax_t>(in.gcount()) != size) {
        throw Error(where, "read only " + std::to_string(in.gcount()) + " of " + std::to_string(size) + " bytes");
    }
    return bytes;
}

}  // namespace

const char* to_string(CloudEncoding encoding)
{
    switch (encoding) {
    case CloudEncoding::ascii: return "ascii";
    case CloudEncoding::binary: return "binary";
    case CloudEncoding::binary_compressed: return "binary_compressed";
    }
    return "unknown";
}

PointCloud read_cloud(const std::filesystem::path& path, CloudReadReport* report)
{
    const std::string where = path.string();
    const CloudFormat format = format_of(path);
    const std::vector<std::uint8_t> bytes = read_whole_file(path, where);
    CloudReadReport local_report;
    CloudReadReport& filled = report ? *report : local_report;
    filled = CloudReadReport{};
    return format == CloudFormat::pcd ? detail::read_pcd(bytes, where, filled) : detail::read_ply(bytes, where, filled);
}

void write_cloud(const std::filesystem::path& path, const PointCloud& cloud, const CloudWriteOptions& options)
{
    const std::string where = path.string();
    const CloudFormat format = format_of(path);
    check_cloud(cloud, where.c_str());
    // Both readers refuse a file without points, so writing one would only defer the error.
    if (cloud.empty()) throw Error(where, "cloud has no points (a file without points could not be read back)");
    const std::string bytes = format == CloudFormat::pcd ? detail::pcd_file_bytes(cloud, options, where)
                                                         : detail::ply_file_bytes(cloud, options, where);
    write_file_atomically(path, [&](std::ofstream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    });
}

}  // namespace mfpc
