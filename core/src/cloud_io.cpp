#include "mfpc/core/cloud_io.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <span>
#include <string>

#include "cloud_format.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/text_file.hpp"

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

// The whole file (read_text_file: missing, directory, FIFO and unreadable files each get their own
// reason): both formats are parsed from memory, so reading never depends on stream state and
// every bound can be checked against the real size before anything is allocated for points.
std::string read_whole_file(const std::filesystem::path& path)
{
    std::string bytes = read_text_file(path);
    if (bytes.empty()) throw Error(path.string(), "file is empty");
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

CloudEncoding parse_cloud_encoding(std::string_view text, const std::string& where)
{
    for (const CloudEncoding encoding : {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed}) {
        if (text == to_string(encoding)) return encoding;
    }
    throw Error(where, "must be ascii, binary or binary_compressed, got " + detail::quoted(text));
}

void check_cloud_write_options(const std::filesystem::path& path, const CloudWriteOptions& options)
{
    if (format_of(path) == CloudFormat::pcd) return;
    if (options.encoding == CloudEncoding::binary_compressed) {
        throw Error(path.string(), "PLY has no binary_compressed encoding (use ascii or binary)");
    }
    if (options.organized) throw Error(path.string(), "PLY cannot store an organized grid (write .pcd for that)");
}

PointCloud read_cloud(const std::filesystem::path& path, CloudReadReport* report)
{
    const std::string where = path.string();
    const CloudFormat format = format_of(path);
    const std::string file = read_whole_file(path);
    // The parsers take bytes; char data may be read as unsigned char, so no copy is needed.
    const std::span<const std::uint8_t> bytes(reinterpret_cast<const std::uint8_t*>(file.data()), file.size());
    CloudReadReport local_report;
    CloudReadReport& filled = report ? *report : local_report;
    filled = CloudReadReport{};
    return format == CloudFormat::pcd ? detail::read_pcd(bytes, where, filled) : detail::read_ply(bytes, where, filled);
}

std::string cloud_file_bytes(const std::filesystem::path& path, const PointCloud& cloud, const CloudWriteOptions& options)
{
    const std::string where = path.string();
    check_cloud_write_options(path, options);
    const CloudFormat format = format_of(path);
    check_cloud(cloud, where.c_str());
    // Both readers refuse a file without points, so writing one would only defer the error.
    if (cloud.empty()) throw Error(where, "cloud has no points (a file without points could not be read back)");
    return format == CloudFormat::pcd ? detail::pcd_file_bytes(cloud, options, where)
                                      : detail::ply_file_bytes(cloud, options, where);
}

void write_cloud(const std::filesystem::path& path, const PointCloud& cloud, const CloudWriteOptions& options)
{
    const std::string bytes = cloud_file_bytes(path, cloud, options);
    write_file_atomically(path, [&](std::ofstream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    });
}

}  // namespace mfpc
