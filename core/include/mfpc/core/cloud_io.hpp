#pragma once

/// @file
/// @brief PCD (.pcd) and PLY (.ply) reading and writing. The format is chosen by the file
/// extension.
///
/// Reading keeps only finite points (x, y and z all finite) and, in an organized PCD, takes a pixel
/// at exactly (0, 0, 0) for missing depth, as NaN (see CloudReadReport::points_zero); a point
/// beyond ±max_coordinate is an error. The index map of the returned cloud
/// records the source position of every kept point, so an organized 640x480 scan keeps its pixel
/// coordinates. Normals (normal_x/y/z or nx/ny/nz) and colour (rgb/rgba packed, or red/green/blue)
/// are read when present. Any malformed input (missing or unreadable file, bad header, truncated
/// data, extra ascii rows, header/data mismatch, no x y z fields, zero points, zero finite points)
/// throws mfpc::Error naming the file and the reason. Bytes after the binary data are ignored:
/// files written by older PCL versions (the shared Kinect scenes among them) are padded there.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief How the point data of a cloud file is stored.
enum class CloudEncoding {
    ascii,              ///< Text, one point a line.
    binary,             ///< Packed binary values.
    binary_compressed   ///< PCD's LZF-compressed binary (PCD only).
};

/// @brief What read_cloud found in a file.
struct CloudReadReport {
    std::size_t points_in = 0;      ///< Points the file holds (width * height for PCD).
    std::size_t points_finite = 0;  ///< Points kept.
    /// Pixels of an organized PCD at exactly (0, 0, 0): missing depth as some drivers write it,
    /// read as invalid pixels (as NaN) and not kept.
    std::size_t points_zero = 0;
    std::uint32_t width = 0;        ///< Width of the file's point grid.
    std::uint32_t height = 1;       ///< Height of the file's point grid (> 1: organized).
    std::vector<std::string> fields;  ///< Field names as the file gives them.
    CloudEncoding encoding = CloudEncoding::binary;  ///< How the file stores its data.
};

/// @brief Reads a PCD or PLY cloud, keeping its finite points (see the file description).
/// @param path The file; its extension (.pcd or .ply, any case) chooses the format.
/// @param report When given, receives what the file held.
/// @return The finite points with their normals and colours when the file has them, and the
/// source position of each (the index map is empty when every point was kept).
/// @throws mfpc::Error naming the file and the reason for an unknown or missing extension and any
/// malformed input: missing, empty or unreadable file, bad header, truncated data, extra ascii
/// rows, header/data mismatch, no x y z fields, zero points, zero finite points.
PointCloud read_cloud(const std::filesystem::path& path, CloudReadReport* report = nullptr);

/// @brief How write_cloud writes a cloud.
struct CloudWriteOptions {
    CloudEncoding encoding = CloudEncoding::binary;  ///< The data encoding.
    /// Write the source grid (width x height, NaN where no point) instead of the point list, so an
    /// organized scan stays organized. Needs a cloud whose index map fits its width x height.
    bool organized = false;
};

/// @brief The bytes of the file write_cloud would write, without writing it: for a caller that
/// writes several outputs all or none.
/// @param path The file's name: .pcd or .ply (chooses the format; nothing is created).
/// @param cloud The cloud.
/// @param options The encoding, and whether to write the organized source grid.
/// @return The whole file.
/// @throws mfpc::Error as write_cloud does for the options and the cloud.
std::string cloud_file_bytes(const std::filesystem::path& path, const PointCloud& cloud,
                             const CloudWriteOptions& options = {});

/// @brief Writes a cloud as PCD or PLY, chosen by the extension of `path`.
///
/// Writes to a temporary file beside `path` and renames it over `path`, so a failure never leaves a
/// half-written file. PLY supports ascii and binary (little endian); binary_compressed is PCD only.
/// @param path The file to write: .pcd or .ply.
/// @param cloud The cloud; its normals and colours are written when it has them.
/// @param options The encoding, and whether to write the organized source grid.
/// @throws mfpc::Error naming the file when check_cloud_write_options or check_cloud rejects the
/// output or the cloud, for a cloud with no points (it could not be read back), for organized
/// output the index map does not fit (two points on one source position, say), and when the
/// file cannot be created, written or renamed into place.
void write_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                 const CloudWriteOptions& options = {});

/// @brief Checks that a cloud could be written to `path` with `options` (a .pcd or .ply extension;
/// binary_compressed and organized output only for PCD) without touching the file system, so a
/// caller can reject a bad output before long work. write_cloud makes the same checks.
/// @param path The file that would be written.
/// @param options The options it would be written with.
/// @throws mfpc::Error naming `path` for a missing or unknown extension, or a PLY file with
/// binary_compressed encoding or organized output.
void check_cloud_write_options(const std::filesystem::path& path, const CloudWriteOptions& options);

/// @brief The name of an encoding, as parse_cloud_encoding reads it.
/// @param encoding The encoding.
/// @return "ascii", "binary" or "binary_compressed".
const char* to_string(CloudEncoding encoding);
/// @brief The encoding named by `text`.
/// @param text "ascii", "binary" or "binary_compressed".
/// @param where The name of the setting, for the error.
/// @return The encoding.
/// @throws mfpc::Error naming `where` for any other text.
CloudEncoding parse_cloud_encoding(std::string_view text, const std::string& where = "encoding");

}  // namespace mfpc
