#pragma once
// The checks of a cloud that read_cloud accepted, shared by the PCD and PLY targets: what the
// reader documents (finite points, per-point normals and colours, an index map into the source
// grid in source order), what check_cloud asks of every cloud, and that writing it and reading it
// back gives the same cloud.
#include <cstring>
#include <string>

#include "fuzz_support.hpp"
#include "mfpc/core/cloud_io.hpp"

namespace mfpc::fuzz {

inline void check_read_cloud(const PointCloud& cloud, const CloudReadReport& report)
{
    check(!cloud.empty(), "read_cloud returned no points");
    for (const Point& p : cloud.points) check(finite(p), "read_cloud kept a non-finite point");
    check(cloud.normals.empty() || cloud.normals.size() == cloud.size(), "normals and points differ in number");
    check(cloud.colors.empty() || cloud.colors.size() == cloud.size(), "colours and points differ in number");
    check(report.points_finite == cloud.size(), "report.points_finite is not the point count");
    check(report.points_in >= cloud.size(), "more points kept than the file holds");
    if (!cloud.source_index.empty()) {
        check(cloud.source_index.size() == cloud.size(), "index map and points differ in number");
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            check(cloud.source_index[i] < cloud.source_size(), "source position beyond the source grid");
            // Kept in source order: increasing, so no source point twice.
            check(i == 0 || cloud.source_index[i] > cloud.source_index[i - 1], "source positions not increasing");
        }
    }
    try {
        check_cloud(cloud, "read cloud");
    } catch (const Error& error) {
        fail(std::string("check_cloud refuses a cloud read_cloud accepted: ") + error.what());
    }
}

inline bool same_bits(const Point& a, const Point& b) { return std::memcmp(a.data(), b.data(), sizeof(float) * 3) == 0; }

// NaN normals may come back as another NaN; everything else bit for bit.
inline bool same_normal(const Point& a, const Point& b)
{
    for (int axis = 0; axis < 3; ++axis) {
        if (std::isnan(a[axis]) && std::isnan(b[axis])) continue;
        if (std::memcmp(&a[axis], &b[axis], sizeof(float)) != 0) return false;
    }
    return true;
}

/// Writes the cloud as `name` (its extension picks the format) with `encoding`, reads it back and
/// checks that nothing changed: a cloud the reader accepts is one the writer can keep.
inline void check_round_trip(const PointCloud& cloud, const std::string& name, CloudEncoding encoding)
{
    const std::filesystem::path path = scratch_dir() / name;
    PointCloud back;
    try {
        write_cloud(path, cloud, {encoding, false});
        back = read_cloud(path);
    } catch (const Error& error) {
        fail(std::string("a cloud read_cloud accepted does not write and read back: ") + error.what());
    }
    check(back.size() == cloud.size(), "round trip changed the point count");
    check(back.normals.size() == cloud.normals.size(), "round trip changed the normals");
    check(back.colors.size() == cloud.colors.size(), "round trip changed the colours");
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        check(same_bits(back.points[i], cloud.points[i]), "round trip changed a point");
        if (!cloud.normals.empty()) check(same_normal(back.normals[i], cloud.normals[i]), "round trip changed a normal");
        if (!cloud.colors.empty()) check(back.colors[i] == cloud.colors[i], "round trip changed a colour");
    }
}

}  // namespace mfpc::fuzz
