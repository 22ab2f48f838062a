#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// PCD (.pcd) and PLY (.ply) reading and writing. The format is chosen by the file extension.
//
// Reading keeps only finite points (x, y and z all finite); the index map of the returned cloud
// records the source position of every kept point, so an organized 640x480 scan keeps its pixel
// coordinates. Normals (normal_x/y/z or nx/ny/nz) and colour (rgb/rgba packed, or red/green/blue)
// are read when present. Any malformed input (missing or unreadable file, bad header, truncated
// data, extra ascii rows, header/data mismatch, no x y z fields, zero points, zero finite points)
// throws mfpc::Error naming the file and the reason. Bytes after the binary data are ignored:
// files written by older PCL versions (the shared Kinect scenes among them) are padded there.

enum class CloudEncoding { ascii, binary, binary_compressed };

struct CloudReadReport {
    std::size_t points_in = 0;      // points the file holds (width * height for PCD)
    std::size_t points_finite = 0;  // points kept
    std::uint32_t width = 0;
    std::uint32_t height = 1;
    std::vector<std::string> fields;  // field names as the file gives them
    CloudEncoding encoding = CloudEncoding::binary;
};

PointCloud read_cloud(const std::filesystem::path& path, CloudReadReport* report = nullptr);

struct CloudWriteOptions {
    CloudEncoding encoding = CloudEncoding::binary;
    // Write the source grid (width x height, NaN where no point) instead of the point list, so an
    // organized scan stays organized. Needs a cloud whose index map fits its width x height.
    bool organized = false;
};

// Writes to a temporary file beside `path` and renames it over `path`, so a failure never leaves a
// half-written file. PLY supports ascii and binary (little endian); binary_compressed is PCD only.
void write_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                 const CloudWriteOptions& options = {});

// Checks that a cloud could be written to `path` with `options` (a .pcd or .ply extension;
// binary_compressed and organized output only for PCD) without touching the file system, so a
// caller can reject a bad output before long work. write_cloud makes the same checks.
void check_cloud_write_options(const std::filesystem::path& path, const CloudWriteOptions& options);

const char* to_string(CloudEncoding encoding);
// "ascii", "binary" or "binary_compressed"; throws mfpc::Error naming `where` otherwise.
CloudEncoding parse_cloud_encoding(std::string_view text, const std::string& where = "encoding");

}  // namespace mfpc
