#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

// The LZF codec is private to the core module; it is tested directly (against PCL's liblzf copy)
// because a corrupt-block bug would otherwise only show as a wrong cloud.
#include "../../core/src/lzf.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/peak_memory.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::TempDir;

// PCL warns on stderr about fields a point type has and a file lacks (curvature); the tests know.
const bool pcl_quiet = [] {
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
    return true;
}();

constexpr float nan = std::numeric_limits<float>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Helpers

bool same_bits(const Point& a, const Point& b)
{
    return std::memcmp(a.data(), b.data(), 3 * sizeof(float)) == 0;
}

// A cloud whose coordinates include the values text round trips get wrong first: denormals,
// negative zero, the largest coordinate a cloud may hold, thirds, and long random mantissas.
PointCloud random_cloud(std::size_t count, bool normals, bool colors, std::uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-5.0f, 5.0f);
    std::uniform_int_distribution<int> channel(0, 255);
    PointCloud cloud;
    for (std::size_t i = 0; i < count; ++i) {
        Point p(coordinate(rng), coordinate(rng), coordinate(rng));
        if (i % 17 == 3) p.x() = 1e-40f;
        if (i % 19 == 4) p.y() = -0.0f;
        if (i % 23 == 5) p.z() = std::nextafter(max_coordinate, 0.0f);
        if (i % 29 == 6) p.x() = 1.0f / 3.0f;
        cloud.points.push_back(p);
        if (normals) {
            cloud.normals.push_back(Point(coordinate(rng), coordinate(rng), coordinate(rng)).normalized());
        }
        if (colors) {
            cloud.colors.push_back(Rgb{static_cast<std::uint8_t>(channel(rng)), static_cast<std::uint8_t>(channel(rng)),
                                       static_cast<std::uint8_t>(channel(rng))});
        }
    }
    cloud.width = static_cast<std::uint32_t>(count);
    cloud.height = 1;
    return cloud;
}

// An organized width x height cloud keeping the cells where `keep` says so, in row-major order.
PointCloud organized_cloud(std::uint32_t width, std::uint32_t height, bool normals, bool colors, std::uint32_t seed)
{
    const PointCloud all = random_cloud(std::size_t(width) * height, normals, colors, seed);
    std::vector<std::uint32_t> kept;
    for (std::uint32_t i = 0; i < width * height; ++i) {
        if (i % 3 != 1 && i % 7 != 2) kept.push_back(i);
    }
    PointCloud cloud = select(all, kept);
    cloud.width = width;
    cloud.height = height;
    return cloud;
}

void expect_same_cloud(const PointCloud& expected, const PointCloud& actual)
{
    ASSERT_EQ(expected.size(), actual.size());
    EXPECT_EQ(expected.width, actual.width);
    EXPECT_EQ(expected.height, actual.height);
    EXPECT_EQ(expected.source_index, actual.source_index);
    ASSERT_EQ(expected.normals.size(), actual.normals.size());
    ASSERT_EQ(expected.colors.size(), actual.colors.size());
    std::size_t point_mismatches = 0;
    std::size_t normal_mismatches = 0;
    std::size_t color_mismatches = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
        if (!same_bits(expected.points[i], actual.points[i])) {
            if (point_mismatches++ == 0) {
                ADD_FAILURE() << "point " << i << ": " << expected.points[i].transpose() << " vs "
                              << actual.points[i].transpose();
            }
        }
        if (expected.has_normals() && !same_bits(expected.normals[i], actual.normals[i])) ++normal_mismatches;
        if (expected.has_colors() && !(expected.colors[i] == actual.colors[i])) ++color_mismatches;
    }
    EXPECT_EQ(point_mismatches, 0u);
    EXPECT_EQ(normal_mismatches, 0u);
    EXPECT_EQ(color_mismatches, 0u);
}

// Our read of a file against PCL's read of the same file: every finite PCL point, in order, is
// ours with the same bits, and our source index says where it was.
template <typename PointT>
void expect_matches_pcl(const pcl::PointCloud<PointT>& theirs, const PointCloud& ours, bool normals, bool colors)
{
    std::size_t kept = 0;
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < theirs.size(); ++i) {
        const PointT& p = theirs[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
        ASSERT_LT(kept, ours.size());
        bool same = ours.source_position(kept) == i && same_bits(ours.points[kept], Point(p.x, p.y, p.z));
        if constexpr (pcl::traits::has_normal_v<PointT>) {
            if (normals) same = same && same_bits(ours.normals[kept], Point(p.normal_x, p.normal_y, p.normal_z));
        }
        if constexpr (pcl::traits::has_color_v<PointT>) {
            if (colors) same = same && ours.colors[kept] == Rgb{p.r, p.g, p.b};
        }
        if (!same && mismatches++ == 0) {
            ADD_FAILURE() << "first mismatch at PCL point " << i << " (" << p << "), ours " << kept << " from "
                          << ours.source_position(kept) << " (" << ours.points[kept].transpose() << ")";
        }
        ++kept;
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_EQ(kept, ours.size());
    EXPECT_EQ(ours.has_normals(), normals);
    EXPECT_EQ(ours.has_colors(), colors);
}

std::string bytes_of(std::span<const float> values)
{
    return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
}

std::string read_file(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<std::string> files_in(const std::filesystem::path& directory)
{
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(directory)) {
        names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

// Reading `path` throws mfpc::Error whose one-line message names the file and contains `reason`.
::testing::AssertionResult read_fails_with(const std::filesystem::path& path, const std::string& reason)
{
    try {
        read_cloud(path);
    } catch (const Error& error) {
        const std::string message = error.what();
        if (message.find(path.string()) == std::string::npos) {
            return ::testing::AssertionFailure() << "message does not name the file: " << message;
        }
        if (message.find(reason) == std::string::npos) {
            return ::testing::AssertionFailure() << "message lacks \"" << reason << "\": " << message;
        }
        if (message.find('\n') != std::string::npos) {
            return ::testing::AssertionFailure() << "message is not one line: " << message;
        }
        return ::testing::AssertionSuccess() << message;
    } catch (const std::exception& other) {
        return ::testing::AssertionFailure() << "threw something other than mfpc::Error: " << other.what();
    }
    return ::testing::AssertionFailure() << "read " << path << " without an error";
}

const std::string xyz_header_start = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";

std::string xyz_pcd(const std::string& size_lines, const std::string& data_line, const std::string& data)
{
    return xyz_header_start + size_lines + "VIEWPOINT 0 0 0 1 0 0 0\n" + data_line + "\n" + data;
}

struct Encoded {
    const char* extension;
    CloudEncoding encoding;
};

const Encoded all_encodings[] = {{".pcd", CloudEncoding::ascii},
                                 {".pcd", CloudEncoding::binary},
                                 {".pcd", CloudEncoding::binary_compressed},
                                 {".ply", CloudEncoding::ascii},
                                 {".ply", CloudEncoding::binary}};

std::string name_of(const Encoded& encoded, const std::string& stem)
{
    return stem + "_" + to_string(encoded.encoding) + encoded.extension;
}

// ---------------------------------------------------------------------------------------------
// Round trips through our own writer and reader

TEST(CloudIo, RoundTripIsBitExactForEveryFormatAndAttributeSet)
{
    TempDir dir;
    for (const Encoded& encoded : all_encodings) {
        for (const auto& [normals, colors] : {std::pair{false, false}, {true, false}, {false, true}, {true, true}}) {
            SCOPED_TRACE(std::string(encoded.extension) + " " + to_string(encoded.encoding) + " normals " +
                         std::to_string(normals) + " colours " + std::to_string(colors));
            const PointCloud cloud = random_cloud(1000, normals, colors, 7);
            const auto path = dir / name_of(encoded, "round_trip");
            write_cloud(path, cloud, {encoded.encoding, false});
            CloudReadReport report;
            const PointCloud back = read_cloud(path, &report);
            expect_same_cloud(cloud, back);
            EXPECT_TRUE(back.source_index.empty());
            EXPECT_EQ(report.points_in, 1000u);
            EXPECT_EQ(report.points_finite, 1000u);
            EXPECT_EQ(report.width, 1000u);
            EXPECT_EQ(report.height, 1u);
            EXPECT_EQ(report.encoding, encoded.encoding);
            const bool pcd = std::string(encoded.extension) == ".pcd";
            std::vector<std::string> fields = {"x", "y", "z"};
            if (normals) {
                for (const char* name : pcd ? std::vector{"normal_x", "normal_y", "normal_z"} : std::vector{"nx", "ny", "nz"}) {
                    fields.push_back(name);
                }
            }
            if (colors) {
                for (const char* name : pcd ? std::vector{"rgb"} : std::vector{"red", "green", "blue"}) {
                    fields.push_back(name);
                }
            }
            EXPECT_EQ(report.fields, fields);
        }
    }
}

TEST(CloudIo, OrganizedRoundTripKeepsGridAndSourceIndex)
{
    TempDir dir;
    for (const CloudEncoding encoding :
         {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed}) {
        SCOPED_TRACE(to_string(encoding));
        const PointCloud cloud = organized_cloud(16, 12, true, true, 11);
        ASSERT_LT(cloud.size(), cloud.source_size());
        const auto path = dir / (std::string("organized_") + to_string(encoding) + ".pcd");
        write_cloud(path, cloud, {encoding, true});
        CloudReadReport report;
        const PointCloud back = read_cloud(path, &report);
        expect_same_cloud(cloud, back);
        EXPECT_EQ(report.points_in, 16u * 12u);
        EXPECT_EQ(report.points_finite, cloud.size());
        EXPECT_EQ(report.width, 16u);
        EXPECT_EQ(report.height, 12u);
    }
}

TEST(CloudIo, UnorganizedReadDropsNonFinitePointsAndKeepsTheirPositions)
{
    TempDir dir;
    const auto path = dir.write("holes.pcd", xyz_pcd("WIDTH 5\nHEIGHT 1\nPOINTS 5\n", "DATA ascii",
                                                     "1 2 3\nnan 0 0\n4 5 6\n7 inf 8\n9 10 11\n"));
    CloudReadReport report;
    const PointCloud cloud = read_cloud(path, &report);
    ASSERT_EQ(cloud.size(), 3u);
    EXPECT_EQ(cloud.source_index, (std::vector<std::uint32_t>{0, 2, 4}));
    EXPECT_EQ(cloud.width, 5u);
    EXPECT_EQ(cloud.height, 1u);
    EXPECT_EQ(cloud.points[2], Point(9, 10, 11));
    EXPECT_EQ(report.points_in, 5u);
    EXPECT_EQ(report.points_finite, 3u);
    check_cloud(cloud, "holes");
}

// Older PCL padded binary files (the shared scene ends in 3901 zero bytes); PCL ignores the padding,
// and so do we, in both binary PCD encodings and binary PLY.
TEST(CloudIo, BytesAfterBinaryDataAreIgnored)
{
    TempDir dir;
    const PointCloud cloud = random_cloud(50, true, true, 13);
    for (const Encoded& encoded : all_encodings) {
        if (encoded.encoding == CloudEncoding::ascii) continue;
        SCOPED_TRACE(name_of(encoded, "padded"));
        const auto path = dir / name_of(encoded, "padded");
        write_cloud(path, cloud, {encoded.encoding, false});
        dir.write(path.filename().string(), read_file(path) + std::string(3901, '\0'));
        expect_same_cloud(cloud, read_cloud(path));
    }
}

TEST(CloudIo, NonFiniteNormalOfAFinitePointIsKeptAsRead)
{
    TempDir dir;
    const auto path = dir.write(
        "normals.pcd", "VERSION .7\nFIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n"
                       "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3 nan nan nan\n4 5 6 0 0 1\n");
    const PointCloud cloud = read_cloud(path);
    ASSERT_EQ(cloud.size(), 2u);
    EXPECT_TRUE(std::isnan(cloud.normals[0].x()));
    EXPECT_EQ(cloud.normals[1], Point(0, 0, 1));
}

TEST(CloudIo, PcdReadsEveryNumberTypeAndSkipsMultiValueFields)
{
    // x as double, y as int16, z as uint8, between them fields with COUNT > 1 and odd sizes that
    // must be skipped with the right offsets, in all three encodings.
    TempDir dir;
    const std::string header_fields = "FIELDS pad x y skip z rgba\nSIZE 1 8 2 4 1 4\nTYPE U F I F U U\nCOUNT 3 1 1 2 1 1\n";
    std::string records;
    std::string soa[6];
    const auto append = [](std::string& out, const auto& value) {
        out.append(reinterpret_cast<const char*>(&value), sizeof(value));
    };
    const std::uint8_t pads[3] = {9, 9, 9};
    for (int i = 0; i < 4; ++i) {
        const double x = 0.5 + i;
        const std::int16_t y = static_cast<std::int16_t>(-1000 * i);
        const float skip[2] = {nan, 1.0f};
        const std::uint8_t z = static_cast<std::uint8_t>(200 + i);
        const std::uint32_t rgba = 0x80102030u + static_cast<std::uint32_t>(i);
        records.append(reinterpret_cast<const char*>(pads), 3);
        append(records, x);
        append(records, y);
        records.append(reinterpret_cast<const char*>(skip), sizeof(skip));
        append(records, z);
        append(records, rgba);
        soa[0].append(reinterpret_cast<const char*>(pads), 3);
        append(soa[1], x);
        append(soa[2], y);
        soa[3].append(reinterpret_cast<const char*>(skip), sizeof(skip));
        append(soa[4], z);
        append(soa[5], rgba);
    }
    std::string by_field;
    for (const std::string& block : soa) by_field += block;
    const std::vector<std::uint8_t> compressed =
        detail::lzf_compress(std::span(reinterpret_cast<const std::uint8_t*>(by_field.data()), by_field.size()));
    std::string compressed_data;
    append(compressed_data, static_cast<std::uint32_t>(compressed.size()));
    append(compressed_data, static_cast<std::uint32_t>(by_field.size()));
    compressed_data.append(reinterpret_cast<const char*>(compressed.data()), compressed.size());
    std::string ascii;
    for (int i = 0; i < 4; ++i) {
        ascii += "9 9 9 " + std::to_string(0.5 + i) + " " + std::to_string(-1000 * i) + " nan 1 " +
                 std::to_string(200 + i) + " " + std::to_string(0x80102030u + unsigned(i)) + "\n";
    }
    const std::string start = "VERSION 0.7\n" + header_fields + "WIDTH 2\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\n";
    const std::pair<std::string, std::string> files[] = {{"DATA ascii\n", ascii},
                                                         {"DATA binary\n", records},
                                                         {"DATA binary_compressed\n", compressed_data}};
    for (const auto& [data_line, data] : files) {
        SCOPED_TRACE(data_line);
        const auto path = dir.write("types.pcd", start + data_line + data);
        CloudReadReport report;
        const PointCloud cloud = read_cloud(path, &report);
        ASSERT_EQ(cloud.size(), 4u);
        EXPECT_EQ(cloud.width, 2u);
        EXPECT_EQ(cloud.height, 2u);
        EXPECT_TRUE(cloud.source_index.empty());
        for (int i = 0; i < 4; ++i) {
            EXPECT_EQ(cloud.points[i], Point(0.5f + i, -1000.0f * i, 200.0f + i));
            EXPECT_EQ(cloud.colors[i], (Rgb{0x10, 0x20, static_cast<std::uint8_t>(0x30 + i)}));
        }
        EXPECT_EQ(report.fields, (std::vector<std::string>{"pad", "x", "y", "skip", "z", "rgba"}));
    }
}

TEST(CloudIo, PlySkipsElementsAndListsBeforeAndAfterTheVertices)
{
    TempDir dir;
    const std::string ascii =
        "ply\nformat ascii 1.0\ncomment made by hand\nobj_info none\n"
        "element material 2\nproperty list uchar int ids\nproperty float shine\n"
        "element vertex 3\nproperty double x\nproperty float y\nproperty list uint short extra\nproperty int z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "3 1 2 3 0.5\n0 1.5\n"
        "1 2 2 7 8 3 10 20 30 255\n4 5 0 6 40 50 60 255\n-1 -2 1 9 -3 70 80 90 255\n"
        "3 0 1 2\n3 2 1 0\n";
    const auto check = [](const PointCloud& cloud) {
        ASSERT_EQ(cloud.size(), 3u);
        EXPECT_EQ(cloud.points[0], Point(1, 2, 3));
        EXPECT_EQ(cloud.points[1], Point(4, 5, 6));
        EXPECT_EQ(cloud.points[2], Point(-1, -2, -3));
        EXPECT_EQ(cloud.colors[2], (Rgb{70, 80, 90}));
        EXPECT_FALSE(cloud.has_normals());
    };
    check(read_cloud(dir.write("lists_ascii.ply", ascii)));

    // The same file in both binary byte orders.
    for (const bool big_endian : {false, true}) {
        SCOPED_TRACE(big_endian ? "big endian" : "little endian");
        std::string data;
        const auto put = [&](const auto& value) {
            char bytes[sizeof(value)];
            std::memcpy(bytes, &value, sizeof(value));
            if (big_endian) std::reverse(bytes, bytes + sizeof(value));
            data.append(bytes, sizeof(value));
        };
        put(std::uint8_t(3)), put(1), put(2), put(3), put(0.5f);
        put(std::uint8_t(0)), put(1.5f);
        const double xs[3] = {1, 4, -1};
        const float ys[3] = {2, 5, -2};
        const std::vector<std::vector<std::int16_t>> extras = {{7, 8}, {}, {9}};
        const int zs[3] = {3, 6, -3};
        const std::uint8_t rgb[3][3] = {{10, 20, 30}, {40, 50, 60}, {70, 80, 90}};
        for (int v = 0; v < 3; ++v) {
            put(xs[v]);
            put(ys[v]);
            put(static_cast<std::uint32_t>(extras[v].size()));
            for (std::int16_t e : extras[v]) put(e);
            put(zs[v]);
            for (std::uint8_t c : rgb[v]) put(c);
            put(std::uint8_t(255));
        }
        for (const int first : {0, 2}) {
            put(std::uint8_t(3)), put(first), put(1), put(2 - first);
        }
        std::string header = ascii.substr(0, ascii.find("end_header\n") + 11);
        header.replace(header.find("ascii"), 5, big_endian ? "binary_big_endian" : "binary_little_endian");
        CloudReadReport report;
        check(read_cloud(dir.write("lists_binary.ply", header + data), &report));
        EXPECT_EQ(report.fields,
                  (std::vector<std::string>{"x", "y", "extra", "z", "red", "green", "blue", "alpha"}));
        EXPECT_EQ(report.encoding, CloudEncoding::binary);
    }
}

// PCL spells normals normal_x normal_y normal_z (its PCD files, and PLY from some writers), other
// tools nx ny nz; both formats read either spelling, and refuse a file that gives both.
TEST(CloudIo, NormalsReadUnderEitherSpelling)
{
    TempDir dir;
    const auto check = [](const PointCloud& cloud) {
        ASSERT_EQ(cloud.size(), 2u);
        ASSERT_TRUE(cloud.has_normals());
        EXPECT_EQ(cloud.points[1], Point(4, 5, 6));
        EXPECT_EQ(cloud.normals[0], Point(0, 0, 1));
        EXPECT_EQ(cloud.normals[1], Point(0.6f, 0.8f, 0));
    };
    const std::string rows = "1 2 3 0 0 1\n4 5 6 0.6 0.8 0\n";
    const std::vector<float> values = {1, 2, 3, 0, 0, 1, 4, 5, 6, 0.6f, 0.8f, 0};
    for (const std::string names : {"normal_x normal_y normal_z", "nx ny nz"}) {
        SCOPED_TRACE(names);
        std::string ply_properties;
        for (std::size_t start = 0; start < names.size();) {
            const std::size_t end = std::min(names.find(' ', start), names.size());
            ply_properties += "property float " + names.substr(start, end - start) + "\n";
            start = end + 1;
        }
        const std::string ply_header = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                       "property float z\n" + ply_properties + "end_header\n";
        check(read_cloud(dir.write("ascii.ply", ply_header + rows)));
        std::string binary_header = ply_header;
        binary_header.replace(binary_header.find("ascii"), 5, "binary_little_endian");
        check(read_cloud(dir.write("binary.ply", binary_header + bytes_of(values))));

        const std::string pcd_header = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z " + names +
                                       "\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\n"
                                       "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";
        check(read_cloud(dir.write("ascii.pcd", pcd_header + "DATA ascii\n" + rows)));
        check(read_cloud(dir.write("binary.pcd", pcd_header + "DATA binary\n" + bytes_of(values))));
    }

    EXPECT_TRUE(read_fails_with(
        dir.write("both.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                              "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                              "property float normal_x\nend_header\n1 2 3 0 0 1 0\n"),
        "vertex has both nx and normal_x"));
    EXPECT_TRUE(read_fails_with(
        dir.write("part.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                              "property float z\nproperty float normal_x\nproperty float normal_y\nend_header\n"
                              "1 2 3 0 0\n"),
        "normals need all of nx ny nz (or normal_x normal_y normal_z)"));
    const auto pcd = [](const std::string& fields) {
        return "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z " + fields + "\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n"
               "COUNT 1 1 1 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3 0 0 1\n";
    };
    EXPECT_TRUE(read_fails_with(dir.write("both.pcd", pcd("nx ny normal_z")),
                                "normals given both as normal_x normal_y normal_z and as nx ny nz"));
    EXPECT_TRUE(read_fails_with(dir.write("part.pcd", pcd("nx ny curvature")), "normals need all of"));
}

// A double coordinate rounds to the nearest float: the largest float's shortest text is a little
// above it as a double and still rounds down to it; a number past halfway to 2^128 becomes
// infinity, and its point is dropped as non-finite.
TEST(CloudIo, DoubleCoordinatesRoundToTheNearestFloat)
{
    TempDir dir;
    // Beyond float's range a double becomes infinity, a non-finite point the reader drops; just
    // below, it rounds to the largest float, which lies beyond max_coordinate: an error.
    const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                               "property double z\nend_header\n";
    CloudReadReport report;
    const PointCloud cloud =
        read_cloud(dir.write("edge.ply", header + "0.1 -1e9 1\n3.4028236e38 0 0\n1e300 0 0\n"), &report);
    ASSERT_EQ(cloud.size(), 1u);
    EXPECT_EQ(cloud.points[0], Point(0.1f, -1e9f, 1));
    EXPECT_EQ(report.points_in, 3u);
    EXPECT_TRUE(read_fails_with(dir.write("max.ply", header + "3.4028235e38 0 1\n0 0 1\n0 0 2\n"),
                                "point 0 has a coordinate beyond"));
}

// ---------------------------------------------------------------------------------------------
// PCL as the oracle

TEST(CloudIoPcl, PclReadsWhatWeWrite)
{
    TempDir dir;
    for (const Encoded& encoded : all_encodings) {
        SCOPED_TRACE(name_of(encoded, "ours"));
        const PointCloud cloud = random_cloud(500, true, true, 23);
        const auto path = dir / name_of(encoded, "ours");
        write_cloud(path, cloud, {encoded.encoding, false});
        pcl::PointCloud<pcl::PointXYZRGBNormal> theirs;
        const int status = std::string(encoded.extension) == ".pcd" ? pcl::io::loadPCDFile(path.string(), theirs)
                                                                    : pcl::io::loadPLYFile(path.string(), theirs);
        ASSERT_EQ(status, 0);
        ASSERT_EQ(theirs.size(), cloud.size());
        expect_matches_pcl(theirs, cloud, true, true);
    }
}

TEST(CloudIoPcl, PclReadsOurOrganizedGridWithNaNHoles)
{
    TempDir dir;
    const PointCloud cloud = organized_cloud(20, 10, false, true, 29);
    for (const CloudEncoding encoding :
         {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed}) {
        SCOPED_TRACE(to_string(encoding));
        const auto path = dir / (std::string("grid_") + to_string(encoding) + ".pcd");
        write_cloud(path, cloud, {encoding, true});
        pcl::PointCloud<pcl::PointXYZRGBA> theirs;
        ASSERT_EQ(pcl::io::loadPCDFile(path.string(), theirs), 0);
        EXPECT_EQ(theirs.width, 20u);
        EXPECT_EQ(theirs.height, 10u);
        EXPECT_FALSE(theirs.is_dense);
        expect_matches_pcl(theirs, cloud, false, true);
    }
}

pcl::PointCloud<pcl::PointXYZRGBNormal> random_pcl_cloud(std::uint32_t width, std::uint32_t height, bool holes,
                                                         std::uint32_t seed)
{
    const PointCloud source = random_cloud(std::size_t(width) * height, true, true, seed);
    pcl::PointCloud<pcl::PointXYZRGBNormal> cloud(width, height);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        pcl::PointXYZRGBNormal& p = cloud[i];
        p.x = source.points[i].x();
        p.y = source.points[i].y();
        p.z = source.points[i].z();
        p.normal_x = source.normals[i].x();
        p.normal_y = source.normals[i].y();
        p.normal_z = source.normals[i].z();
        p.curvature = 0.25f;
        p.r = source.colors[i].r;
        p.g = source.colors[i].g;
        p.b = source.colors[i].b;
        p.a = 255;
        if (holes && i % 5 == 2) p.x = p.y = p.z = nan;
    }
    cloud.is_dense = !holes;
    return cloud;
}

TEST(CloudIoPcl, WeReadWhatPclWritesInEveryPcdEncoding)
{
    TempDir dir;
    const auto cloud = random_pcl_cloud(24, 16, true, 31);
    const auto ascii = dir / "pcl_ascii.pcd";
    const auto binary = dir / "pcl_binary.pcd";
    const auto compressed = dir / "pcl_compressed.pcd";
    ASSERT_EQ(pcl::io::savePCDFileASCII(ascii.string(), cloud), 0);
    ASSERT_EQ(pcl::io::savePCDFileBinary(binary.string(), cloud), 0);
    ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(compressed.string(), cloud), 0);
    for (const auto& [path, encoding] : {std::pair{ascii, CloudEncoding::ascii}, {binary, CloudEncoding::binary},
                                        {compressed, CloudEncoding::binary_compressed}}) {
        SCOPED_TRACE(path.filename().string());
        // PCL's own reading of its file is the reference (its ascii keeps 8 digits, not all 9).
        pcl::PointCloud<pcl::PointXYZRGBNormal> theirs;
        ASSERT_EQ(pcl::io::loadPCDFile(path.string(), theirs), 0);
        CloudReadReport report;
        const PointCloud ours = read_cloud(path, &report);
        EXPECT_EQ(report.encoding, encoding);
        EXPECT_EQ(report.points_in, 24u * 16u);
        EXPECT_EQ(ours.width, 24u);
        EXPECT_EQ(ours.height, 16u);
        expect_matches_pcl(theirs, ours, true, true);
    }
}

TEST(CloudIoPcl, WeReadWhatPclWritesAsPly)
{
    TempDir dir;
    const auto cloud = random_pcl_cloud(300, 1, false, 37);
    for (const bool binary : {false, true}) {
        SCOPED_TRACE(binary ? "binary" : "ascii");
        const auto path = dir / (binary ? "pcl_binary.ply" : "pcl_ascii.ply");
        ASSERT_EQ(pcl::io::savePLYFile(path.string(), cloud, binary), 0);
        pcl::PointCloud<pcl::PointXYZRGBNormal> theirs;
        ASSERT_EQ(pcl::io::loadPLYFile(path.string(), theirs), 0);
        ASSERT_EQ(theirs.size(), 300u);
        CloudReadReport report;
        const PointCloud ours = read_cloud(path, &report);
        EXPECT_EQ(report.encoding, binary ? CloudEncoding::binary : CloudEncoding::ascii);
        expect_matches_pcl(theirs, ours, true, true);
    }
}

// ---------------------------------------------------------------------------------------------
// LZF

std::vector<std::uint8_t> lzf_round_trip(const std::vector<std::uint8_t>& data)
{
    const std::vector<std::uint8_t> compressed = detail::lzf_compress(data);
    std::vector<std::uint8_t> back(data.size());
    detail::lzf_decompress(compressed, back, "round trip");
    return back;
}

std::vector<std::vector<std::uint8_t>> lzf_samples()
{
    std::mt19937 rng(41);
    std::vector<std::vector<std::uint8_t>> samples;
    std::vector<std::uint8_t> random(200000);
    for (auto& byte : random) byte = static_cast<std::uint8_t>(rng());
    samples.push_back(random);
    samples.push_back(std::vector<std::uint8_t>(1 << 20, 0));  // one long run
    std::vector<std::uint8_t> period(100003);                  // short periods, overlapping copies
    for (std::size_t i = 0; i < period.size(); ++i) period[i] = static_cast<std::uint8_t>("abc"[i % 3]);
    samples.push_back(period);
    std::vector<std::uint8_t> mixed;  // repeats at distances near the 8192 limit, mixed with noise
    for (int block = 0; block < 40; ++block) {
        for (int i = 0; i < 8190; ++i) mixed.push_back(static_cast<std::uint8_t>(block % 2 ? i * 7 : rng()));
    }
    samples.push_back(mixed);
    samples.push_back({});
    samples.push_back({42});
    samples.push_back({1, 2});
    samples.push_back({5, 5, 5, 5});
    return samples;
}

TEST(Lzf, RoundTripsRandomAndRepetitiveBuffers)
{
    for (const auto& sample : lzf_samples()) {
        SCOPED_TRACE(sample.size());
        EXPECT_EQ(lzf_round_trip(sample), sample);
    }
    const std::vector<std::uint8_t> zeros(1 << 20, 0);
    EXPECT_LT(detail::lzf_compress(zeros).size(), zeros.size() / 50);
}

TEST(Lzf, AgreesWithPclInBothDirections)
{
    for (const auto& sample : lzf_samples()) {
        if (sample.size() < 4) continue;  // PCL's compressor refuses tiny inputs
        SCOPED_TRACE(sample.size());
        const std::vector<std::uint8_t> ours = detail::lzf_compress(sample);
        std::vector<std::uint8_t> pcl_back(sample.size());
        ASSERT_EQ(pcl::lzfDecompress(ours.data(), static_cast<unsigned>(ours.size()), pcl_back.data(),
                                     static_cast<unsigned>(pcl_back.size())),
                  sample.size());
        EXPECT_EQ(pcl_back, sample);

        std::vector<std::uint8_t> theirs(sample.size() * 2 + 64);
        const unsigned theirs_size = pcl::lzfCompress(sample.data(), static_cast<unsigned>(sample.size()),
                                                      theirs.data(), static_cast<unsigned>(theirs.size()));
        ASSERT_GT(theirs_size, 0u);
        theirs.resize(theirs_size);
        std::vector<std::uint8_t> our_back(sample.size());
        detail::lzf_decompress(theirs, our_back, "pcl block");
        EXPECT_EQ(our_back, sample);
    }
}

TEST(Lzf, CorruptBlocksThrowInsteadOfOverrunning)
{
    std::vector<std::uint8_t> out(16);
    const auto fails = [&](std::vector<std::uint8_t> block, const std::string& reason) {
        try {
            detail::lzf_decompress(block, out, "block");
        } catch (const Error& error) {
            return std::string(error.what()).find(reason) != std::string::npos;
        }
        return false;
    };
    EXPECT_TRUE(fails({0x20, 0x00}, "points before the start"));          // reference with nothing written
    EXPECT_TRUE(fails({0x05, 1, 2}, "reaches past the end"));             // literal run longer than the block
    EXPECT_TRUE(fails({0x00, 1, 0xe0}, "cut off"));                       // reference missing its bytes
    EXPECT_TRUE(fails({0x00, 1, 0xe0, 0xff, 0x00}, "more than the 16"));  // reference longer than the output
    EXPECT_TRUE(fails({0x02, 1, 2, 3}, "decompresses to 3 bytes, 16"));   // too short
}

// ---------------------------------------------------------------------------------------------
// Real data

TEST(CloudIoShared, SceneMatchesPclOrganizedLoad)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    CloudReadReport report;
    const PointCloud ours = read_cloud(path, &report);
    EXPECT_EQ(report.points_in, 307200u);
    EXPECT_EQ(report.points_finite, 241407u);
    EXPECT_EQ(report.width, 640u);
    EXPECT_EQ(report.height, 480u);
    EXPECT_EQ(report.encoding, CloudEncoding::binary_compressed);
    EXPECT_EQ(report.fields, (std::vector<std::string>{"x", "y", "z", "rgba"}));
    ASSERT_EQ(ours.size(), 241407u);
    EXPECT_EQ(ours.width, 640u);
    EXPECT_EQ(ours.height, 480u);
    ASSERT_EQ(ours.source_index.size(), ours.size());
    EXPECT_NO_THROW(check_cloud(ours, "scene"));

    pcl::PointCloud<pcl::PointXYZRGBA> theirs;
    ASSERT_EQ(pcl::io::loadPCDFile(path.string(), theirs), 0);
    ASSERT_EQ(theirs.width, 640u);
    ASSERT_EQ(theirs.height, 480u);
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < ours.size(); ++i) {
        const pcl::PointXYZRGBA& p = theirs[ours.source_index[i]];
        const bool same = std::isfinite(p.x) && same_bits(ours.points[i], Point(p.x, p.y, p.z)) &&
                          ours.colors[i] == Rgb{p.r, p.g, p.b};
        if (!same) ++mismatches;
    }
    EXPECT_EQ(mismatches, 0u);
    expect_matches_pcl(theirs, ours, false, true);
}

TEST(CloudIoShared, SceneSurvivesAnOrganizedRoundTrip)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    const PointCloud scene = read_cloud(path);
    TempDir dir;
    for (const CloudEncoding encoding : {CloudEncoding::binary, CloudEncoding::binary_compressed}) {
        const auto copy = dir / "scene.pcd";
        write_cloud(copy, scene, {encoding, true});
        expect_same_cloud(scene, read_cloud(copy));
    }
}

TEST(CloudIoShared, MilkModelEqualsPclLoad)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    CloudReadReport report;
    const PointCloud ours = read_cloud(path, &report);
    EXPECT_EQ(report.encoding, CloudEncoding::binary_compressed);
    EXPECT_EQ(report.points_in, 13704u);
    pcl::PointCloud<pcl::PointXYZ> theirs;
    ASSERT_EQ(pcl::io::loadPCDFile(path.string(), theirs), 0);
    ASSERT_EQ(theirs.size(), 13704u);
    ASSERT_EQ(ours.size(), 13704u);
    EXPECT_TRUE(ours.source_index.empty());
    expect_matches_pcl(theirs, ours, false, false);
}

// ---------------------------------------------------------------------------------------------
// Malformed input: each case names the file and says what is wrong

TEST(CloudIoErrors, FileSystemProblems)
{
    TempDir dir;
    EXPECT_TRUE(read_fails_with(dir / "missing.pcd", "no such file"));
    std::filesystem::create_directory(dir / "folder.pcd");
    EXPECT_TRUE(read_fails_with(dir / "folder.pcd", "is a directory"));
    EXPECT_TRUE(read_fails_with(dir.write("empty.pcd", ""), "file is empty"));
    EXPECT_TRUE(read_fails_with(dir.write("empty.ply", ""), "file is empty"));
    EXPECT_TRUE(read_fails_with(dir.write("cloud.xyz", "1 2 3\n"), "unknown extension '.xyz'"));
    EXPECT_TRUE(read_fails_with(dir.write("cloud", "1 2 3\n"), "no file extension"));
}

TEST(CloudIoErrors, PcdHeaderProblems)
{
    TempDir dir;
    const std::string sizes = "WIDTH 2\nHEIGHT 1\nPOINTS 2\n";
    const std::string rows = "1 2 3\n4 5 6\n";
    const auto file = [&](const std::string& name, const std::string& text) { return dir.write(name, text); };

    EXPECT_TRUE(read_fails_with(file("points.pcd", xyz_pcd("WIDTH 2\nHEIGHT 2\nPOINTS 5\n", "DATA ascii", rows)),
                                "POINTS 5 does not match WIDTH x HEIGHT = 2 x 2 = 4"));
    EXPECT_TRUE(read_fails_with(
        file("no_x.pcd", "FIELDS a y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n" + rows),
        "no x field (FIELDS a y z)"));
    EXPECT_TRUE(read_fails_with(file("zero.pcd", xyz_pcd("WIDTH 0\nHEIGHT 1\nPOINTS 0\n", "DATA ascii", "")),
                                "no points"));
    EXPECT_TRUE(read_fails_with(file("all_nan.pcd", xyz_pcd(sizes, "DATA ascii", "nan nan nan\n1 nan 3\n")),
                                "no finite points"));
    EXPECT_TRUE(read_fails_with(file("lz4.pcd", xyz_pcd(sizes, "DATA binary_lz4", "")),
                                "unknown DATA encoding 'binary_lz4'"));
    EXPECT_TRUE(read_fails_with(file("no_data.pcd", xyz_header_start + sizes), "header has no DATA line"));
    EXPECT_TRUE(read_fails_with(file("keyword.pcd", "FIELDS x y z\nCOLOUR red\n"),
                                "line 2: unknown header line 'COLOUR red'"));
    EXPECT_TRUE(read_fails_with(file("version.pcd", "VERSION 0.8\n" + xyz_pcd(sizes, "DATA ascii", rows)),
                                "unsupported VERSION"));
    EXPECT_TRUE(read_fails_with(
        file("type.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 2\nPOINTS 2\nDATA ascii\n" + rows),
        "field z has unknown TYPE 'Q'"));
    EXPECT_TRUE(read_fails_with(
        file("half.pcd", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n" + rows),
        "field z has TYPE F with SIZE 2"));
    EXPECT_TRUE(read_fails_with(
        file("sizes.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n" + rows),
        "SIZE has 2 values for 3 FIELDS"));
    EXPECT_TRUE(read_fails_with(
        file("count.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 2 1 1\nWIDTH 2\nPOINTS 2\nDATA ascii\n"),
        "field x has COUNT 2, expected 1"));
    EXPECT_TRUE(read_fails_with(file("width.pcd", xyz_pcd("WIDTH many\n", "DATA ascii", rows)),
                                "WIDTH needs one non-negative integer"));
    EXPECT_TRUE(read_fails_with(file("too_many.pcd", xyz_pcd("WIDTH 4000000000\nHEIGHT 4000000000\n", "DATA ascii", rows)),
                                "more than 4294967295"));
    std::string garbage(300, '\0');
    for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>(i * 37 + 11);
    EXPECT_TRUE(read_fails_with(file("garbage.pcd", garbage), "unknown header line"));
}

TEST(CloudIoErrors, PcdDataProblems)
{
    TempDir dir;
    const std::string sizes = "WIDTH 4\nHEIGHT 1\nPOINTS 4\n";
    const std::vector<float> three_points = {1, 2, 3, 4, 5, 6, 7, 8, 9};
    const auto file = [&](const std::string& name, const std::string& text) { return dir.write(name, text); };

    EXPECT_TRUE(read_fails_with(file("short.pcd", xyz_pcd(sizes, "DATA binary", bytes_of(three_points))),
                                "binary data is truncated: 36 bytes for 4 points of 12 bytes (48 needed)"));
    EXPECT_TRUE(read_fails_with(file("rows.pcd", xyz_pcd(sizes, "DATA ascii", "1 2 3\n4 5 6\n7 8 9\n")),
                                "ascii data ends after 3 of 4 points"));
    EXPECT_TRUE(read_fails_with(file("more_rows.pcd", xyz_pcd("WIDTH 2\nHEIGHT 1\nPOINTS 2\n", "DATA ascii",
                                                               "1 2 3\n4 5 6\n7 8 9\n")),
                                "line 14: ascii data has more rows than the 2 points announced"));
    EXPECT_TRUE(read_fails_with(file("values.pcd", xyz_pcd(sizes, "DATA ascii", "1 2 3\n4 5\n")),
                                "line 13: 2 values, expected 3"));
    EXPECT_TRUE(read_fails_with(file("word.pcd", xyz_pcd(sizes, "DATA ascii", "1 2 3\n4 five 6\n")),
                                "line 13: 'five' is not a number (field y)"));
    // A header that claims four billion points over a few bytes fails on the size check, before
    // any allocation for them.
    const std::string huge = "WIDTH 4000000000\nHEIGHT 1\nPOINTS 4000000000\n";
    EXPECT_TRUE(read_fails_with(file("huge.pcd", xyz_pcd(huge, "DATA binary", bytes_of(three_points))),
                                "binary data is truncated: 36 bytes for 4000000000 points"));
    EXPECT_TRUE(read_fails_with(file("huge_ascii.pcd", xyz_pcd(huge, "DATA ascii", "1 2 3\n")),
                                "ascii data ends after 1 of 4000000000 points"));
    EXPECT_TRUE(read_fails_with(file("huge_compressed.pcd", xyz_pcd(huge, "DATA binary_compressed",
                                                                     std::string("\x02\0\0\0\x00\x5a\x62\x02", 8) + "ab")),
                                "compressed block announces"));
}

TEST(CloudIoErrors, PcdCompressedProblems)
{
    TempDir dir;
    const auto valid_path = dir / "valid.pcd";
    write_cloud(valid_path, random_cloud(200, false, false, 43), {CloudEncoding::binary_compressed, false});
    const std::string valid = read_file(valid_path);
    const std::size_t data_start = valid.find("DATA binary_compressed\n") + 23;

    EXPECT_TRUE(read_fails_with(dir.write("cut.pcd", valid.substr(0, valid.size() - 10)),
                                "compressed block is truncated"));
    EXPECT_TRUE(read_fails_with(dir.write("cut_sizes.pcd", valid.substr(0, data_start + 5)),
                                "compressed block is truncated: 5 bytes where its two 4-byte sizes should be"));

    // One point (12 bytes): a back-reference before anything was written, then a block that
    // decompresses to too few bytes, then a block too small for the size it announces.
    const std::string header = xyz_pcd("WIDTH 1\nHEIGHT 1\nPOINTS 1\n", "DATA binary_compressed", "");
    const std::string sizes_2_12("\x02\0\0\0\x0c\0\0\0", 8);
    EXPECT_TRUE(read_fails_with(dir.write("backref.pcd", header + sizes_2_12 + std::string("\x20\x00", 2)),
                                "compressed data is corrupt (back-reference at byte 0 points before the start"));
    const std::string sizes_5_12("\x05\0\0\0\x0c\0\0\0", 8);
    EXPECT_TRUE(read_fails_with(dir.write("short_block.pcd", header + sizes_5_12 + std::string("\x03\x01\x02\x03\x04", 5)),
                                "compressed data is corrupt (it decompresses to 4 bytes, 12 announced)"));
    // 100 points (1200 bytes) from a 1-byte block: no LZF block expands that much.
    const std::string sizes_1_1200("\x01\0\0\0\xb0\x04\0\0", 8);
    EXPECT_TRUE(read_fails_with(
        dir.write("tiny_block.pcd",
                  xyz_pcd("WIDTH 100\nHEIGHT 1\nPOINTS 100\n", "DATA binary_compressed", sizes_1_1200 + "a")),
        "compressed data is corrupt (1 bytes cannot decompress to the 1200 announced)"));
    const std::string sizes_2_13("\x02\0\0\0\x0d\0\0\0", 8);
    EXPECT_TRUE(read_fails_with(dir.write("size.pcd", header + sizes_2_13 + "ab"),
                                "compressed block announces 13 bytes, but 1 points of 12 bytes need 12"));
}

// A forged header claims the most a block of that size could hold (88 times it), and the data
// is literal runs that end long before. Zeroing the claimed buffer first cost seconds and
// gigabytes before the decoder found the fault; untouched, the claim costs nothing.
TEST(CloudIoErrors, ForgedCompressedSizeCostsOnlyWhatIsDecoded)
{
    TempDir dir;
    const std::size_t compressed = std::size_t(4) << 20;
    std::string block;
    block.reserve(compressed);
    while (block.size() + 33 <= compressed) block += std::string(1, '\x1f') + std::string(32, 'x');
    const std::uint32_t points = std::uint32_t(std::uint64_t(block.size()) * 88 / 12);
    const std::uint32_t claimed = points * 12;
    std::string sizes(8, '\0');
    const auto block_size = std::uint32_t(block.size());
    std::memcpy(sizes.data(), &block_size, 4);
    std::memcpy(sizes.data() + 4, &claimed, 4);
    const auto path = dir.write("forged.pcd", xyz_pcd("WIDTH " + std::to_string(points) + "\nHEIGHT 1\nPOINTS " +
                                                          std::to_string(points) + "\n",
                                                      "DATA binary_compressed", sizes + block));
    const bool reset = reset_peak_memory();
    const std::size_t before = peak_memory_bytes();
    EXPECT_TRUE(read_fails_with(path, "compressed data is corrupt (it decompresses to "));
    if (reset && before > 0) {
        // The claim is 352 MB; what is decoded is under 4 MB.
        EXPECT_LT(peak_memory_bytes() - before, std::size_t(64) << 20);
    }
}

// Some drivers write (0, 0, 0) for missing depth: in an organized cloud that is an invalid pixel,
// as NaN is (a sensor cannot measure its own centre). A list keeps such a point.
TEST(CloudIo, OrganizedZerosAreInvalidPixels)
{
    TempDir dir;
    for (const char* data : {"DATA ascii", "DATA binary"}) {
        // Pixels 1 and 3 are zeros (one of them -0).
        const std::vector<float> grid = {1, 2, 3, 0, 0, 0, 4, 5, 6, -0.0f, 0, 0};
        std::string body;
        if (std::string(data) == "DATA ascii") {
            body = "1 2 3\n0 0 0\n4 5 6\n-0 0 0\n";
        } else {
            body = bytes_of(grid);
        }
        CloudReadReport report;
        const PointCloud organized = read_cloud(
            dir.write(std::string("grid_") + (data[5] == 'a' ? "a" : "b") + ".pcd",
                      xyz_pcd("WIDTH 2\nHEIGHT 2\nPOINTS 4\n", data, body)),
            &report);
        ASSERT_EQ(organized.size(), 2u) << data;
        EXPECT_EQ(organized.source_index, (std::vector<std::uint32_t>{0, 2}));
        EXPECT_EQ(report.points_zero, 2u);
        EXPECT_EQ(report.points_finite, 2u);
        const PointCloud list =
            read_cloud(dir.write(std::string("list_") + (data[5] == 'a' ? "a" : "b") + ".pcd",
                                 xyz_pcd("WIDTH 4\nHEIGHT 1\nPOINTS 4\n", data, body)),
                       &report);
        EXPECT_EQ(list.size(), 4u) << data;
        EXPECT_EQ(report.points_zero, 0u);
    }
    // A grid of zeros only holds no valid point.
    EXPECT_TRUE(read_fails_with(dir.write("zeros.pcd", xyz_pcd("WIDTH 2\nHEIGHT 2\nPOINTS 4\n", "DATA ascii",
                                                               "0 0 0\n0 0 0\n0 0 0\n0 0 0\n")),
                                "no valid points"));
}

// Beyond ±1e9 no kernel's float arithmetic is safe (FLANN's tree build recursed without end on
// ±1.7e38, Embree asserted on rays from 1e19): every reader and check_cloud say so.
TEST(CloudIoErrors, CoordinatesBeyondTheRange)
{
    TempDir dir;
    EXPECT_TRUE(read_fails_with(dir.write("far.pcd", xyz_pcd("WIDTH 3\nHEIGHT 1\nPOINTS 3\n", "DATA ascii",
                                                             "1 2 3\n1.7e38 0 0\n4 5 6\n")),
                                "point 1 has a coordinate beyond"));
    EXPECT_TRUE(read_fails_with(dir.write("far.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                                     "property float y\nproperty float z\nend_header\n"
                                                     "0 0 1\n0 -2e9 1\n"),
                                "point 1 has a coordinate beyond"));
    const PointCloud edge = read_cloud(dir.write("edge.pcd", xyz_pcd("WIDTH 1\nHEIGHT 1\nPOINTS 1\n", "DATA ascii",
                                                                     "1e9 -1e9 1e9\n")));
    EXPECT_EQ(edge.size(), 1u);
    PointCloud cloud = random_cloud(10, false, false, 5);
    cloud.points[7] = Point(0, 0, 2e9f);
    try {
        check_cloud(cloud, "scene");
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), "scene");
        EXPECT_NE(error.reason().find("point 7 has a coordinate beyond"), std::string::npos) << error.reason();
    }
}

TEST(CloudIoErrors, PlyProblems)
{
    TempDir dir;
    const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nend_header\n";
    const std::vector<float> three_points = {1, 2, 3, 4, 5, 6, 7, 8, 9};
    const auto file = [&](const std::string& name, const std::string& text) { return dir.write(name, text); };

    EXPECT_TRUE(read_fails_with(file("short.ply", header + bytes_of(three_points)),
                                "binary data is truncated: element 'vertex' has 4 items of at least 12 bytes, 36 bytes remain"));
    EXPECT_TRUE(read_fails_with(
        file("short.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                          "property float z\nend_header\n1 2 3\n4 5 6\n7 8 9\n"),
        "ascii data ends in element 'vertex' (item 3 of 4)"));
    EXPECT_TRUE(read_fails_with(
        file("faces.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 2\nproperty list uchar int v\nend_header\n1 2 3\n3 0 0 0\n3 0\n"),
        "ascii data ends in element 'face' (item 1 of 2)"));
    EXPECT_TRUE(read_fails_with(
        file("no_x.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\nend_header\n1 2\n"),
        "vertex element has no x property"));
    EXPECT_TRUE(read_fails_with(file("format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n"),
                                "unknown PLY format 'binary_middle_endian'"));
    EXPECT_TRUE(read_fails_with(file("version.ply", "ply\nformat ascii 2.0\nend_header\n"),
                                "unsupported PLY version '2.0'"));
    EXPECT_TRUE(read_fails_with(file("magic.ply", "pcl\nformat ascii 1.0\n"), "not a PLY file"));
    EXPECT_TRUE(read_fails_with(file("unended.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"),
                                "header has no end_header line"));
    EXPECT_TRUE(read_fails_with(file("no_vertex.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n"),
                                "no vertex element"));
    EXPECT_TRUE(read_fails_with(file("zero.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                                                 "property float y\nproperty float z\nend_header\n"),
                                "no points"));
    EXPECT_TRUE(read_fails_with(file("nan.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                                "property float y\nproperty float z\nend_header\nnan 0 0\n"),
                                "no finite points"));
    EXPECT_TRUE(read_fails_with(
        file("extra.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\nend_header\n1 2 3\n4 5 6\n"),
        "ascii data continues after the last element with '4'"));
    EXPECT_TRUE(read_fails_with(file("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n"),
                                "line 4: unknown property type 'quad'"));
    // Ascii values are checked against their type, in the vertices and in the elements walked past.
    EXPECT_TRUE(read_fails_with(file("int.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\n"
                                                "property float y\nproperty float z\nend_header\n1.5 0 0\n"),
                                "'1.5' is not an int"));
    EXPECT_TRUE(read_fails_with(
        file("word.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int v\nend_header\n1 2 3\n3 0 x 0\n"),
        "'x' is not"));
    EXPECT_TRUE(read_fails_with(
        file("huge.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                         "property float y\nproperty float z\nend_header\n" + bytes_of(three_points)),
        "element 'vertex' has 4000000000 items of at least 12 bytes"));
}

// Every prefix of a valid file, and many files with random bytes changed, either read or throw
// mfpc::Error: never a crash, a hang or anything the sanitizers catch.
TEST(CloudIoErrors, TruncatedAndMutatedFilesNeverCrash)
{
    TempDir dir;
    const PointCloud cloud = organized_cloud(5, 4, true, true, 47);
    std::mt19937 rng(53);
    std::size_t reads = 0;
    std::size_t errors = 0;
    // Each variant gets a new name: truncating an existing file is slow on ext4 (it flushes).
    const auto try_read = [&](const std::string& bytes, const char* extension) {
        const auto path = dir.write("variant_" + std::to_string(reads++) + extension, bytes);
        try {
            const PointCloud back = read_cloud(path);
            check_cloud(back, "variant");
        } catch (const Error&) {
            ++errors;
        }
        std::filesystem::remove(path);
    };
    for (const Encoded& encoded : all_encodings) {
        SCOPED_TRACE(name_of(encoded, "valid"));
        const auto valid_path = dir / name_of(encoded, "valid");
        write_cloud(valid_path, cloud, {encoded.encoding, std::string(encoded.extension) == ".pcd"});
        const std::string valid = read_file(valid_path);
        for (std::size_t length = 0; length < valid.size(); ++length) try_read(valid.substr(0, length), encoded.extension);
        for (int trial = 0; trial < 300; ++trial) {
            std::string mutated = valid;
            const int changes = 1 + static_cast<int>(rng() % 4);
            for (int c = 0; c < changes; ++c) mutated[rng() % mutated.size()] = static_cast<char>(rng());
            try_read(mutated, encoded.extension);
        }
    }
    EXPECT_GT(errors, reads / 2);
}

// ---------------------------------------------------------------------------------------------
// Writing

TEST(CloudIoWrite, RejectsWhatCannotBeWritten)
{
    TempDir dir;
    const PointCloud cloud = random_cloud(10, false, false, 59);
    const auto fails_with = [](const std::function<void()>& write, const std::string& reason) {
        try {
            write();
        } catch (const Error& error) {
            return std::string(error.what()).find(reason) != std::string::npos;
        }
        return false;
    };
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.ply", cloud, {CloudEncoding::binary_compressed, false}); },
                           "PLY has no binary_compressed encoding"));
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.ply", cloud, {CloudEncoding::binary, true}); },
                           "PLY cannot store an organized grid"));
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.txt", cloud); }, "unknown extension '.txt'"));
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.pcd", PointCloud{}); }, "cloud has no points"));

    PointCloud outside = cloud;
    outside.width = 3;
    outside.height = 2;  // 10 points cannot sit in a 3 x 2 grid
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.pcd", outside, {CloudEncoding::binary, true}); },
                           "point 6 has source position 6, outside the 3 x 2 grid"));
    PointCloud shared = cloud;
    shared.source_index.assign(10, 0);
    shared.source_index[4] = 3;
    shared.source_index[5] = 3;
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.pcd", shared, {CloudEncoding::binary, true}); },
                           "share source position"));
    PointCloud broken = cloud;
    broken.normals.resize(3);
    EXPECT_TRUE(fails_with([&] { write_cloud(dir / "c.pcd", broken); }, "3 normals for 10 points"));
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{});
}

TEST(CloudIoWrite, UnorganizedWriteOfAnOrganizedCloudListsItsPoints)
{
    TempDir dir;
    const PointCloud cloud = organized_cloud(8, 4, false, false, 61);
    write_cloud(dir / "list.pcd", cloud, {CloudEncoding::binary, false});
    const PointCloud back = read_cloud(dir / "list.pcd");
    EXPECT_EQ(back.width, cloud.size());
    EXPECT_EQ(back.height, 1u);
    EXPECT_TRUE(back.source_index.empty());
    ASSERT_EQ(back.size(), cloud.size());
    for (std::size_t i = 0; i < back.size(); ++i) EXPECT_TRUE(same_bits(back.points[i], cloud.points[i]));
}

TEST(AtomicFile, MissingDirectoryThrowsAndCreatesNothing)
{
    TempDir dir;
    const auto path = dir / "missing" / "cloud.pcd";
    try {
        write_cloud(path, random_cloud(5, false, false, 67));
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_NE(message.find(path.string()), std::string::npos) << message;
        EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
    }
    EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{});
}

TEST(AtomicFile, FailureMidWriteKeepsTheOldFileAndLeavesNoTemporary)
{
    TempDir dir;
    const auto path = dir.write("cloud.pcd", "old contents");
    try {
        write_file_atomically(path, [](std::ofstream& out) {
            out << "half of the new contents";
            throw std::runtime_error("disk on fire");
        });
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), path.string());
        EXPECT_EQ(error.reason(), "disk on fire");
    }
    EXPECT_EQ(read_file(path), "old contents");
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"cloud.pcd"});

    // An mfpc::Error from the callback comes through unchanged.
    try {
        write_file_atomically(path, [](std::ofstream&) { throw Error("elsewhere", "own reason"); });
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), "elsewhere");
    }
    EXPECT_EQ(read_file(path), "old contents");
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"cloud.pcd"});
}

TEST(AtomicFile, SuccessfulWriteReplacesTheFile)
{
    TempDir dir;
    const auto path = dir.write("cloud.ply", "old contents");
    const PointCloud cloud = random_cloud(20, true, false, 71);
    write_cloud(path, cloud, {CloudEncoding::ascii, false});
    expect_same_cloud(cloud, read_cloud(path));
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"cloud.ply"});
    std::filesystem::create_directory(dir / "taken.pcd");
    EXPECT_THROW(write_cloud(dir / "taken.pcd", cloud), Error);
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"cloud.ply", "taken.pcd"}));
}

// A command's outputs all or none: nothing of a failed set reaches a target.
TEST(AtomicFile, StagedFilesAreAllOrNone)
{
    TempDir dir;
    const auto kept = dir.write("a.txt", "old a");
    {
        StagedFiles outputs;
        outputs.stage(kept, std::string("new a"));
        outputs.stage(dir / "b.txt", std::string("new b"));
        std::filesystem::create_directory(dir / "c.txt");
        EXPECT_THROW(outputs.stage(dir / "c.txt", std::string("new c")), Error);
        // Destroyed without commit: the staged temporaries go, the targets stay.
    }
    EXPECT_EQ(read_file(kept), "old a");
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"a.txt", "c.txt"}));

    StagedFiles outputs;
    outputs.stage(kept, std::string("new a"));
    outputs.stage(dir / "b.txt", [](std::ofstream& out) { out << "new b"; });
    outputs.commit();
    EXPECT_EQ(read_file(kept), "new a");
    EXPECT_EQ(read_file(dir / "b.txt"), "new b");
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"a.txt", "b.txt", "c.txt"}));
}

// A rename failing inside commit() puts back what was already replaced.
TEST(AtomicFile, FailedCommitPutsBackWhatItReplaced)
{
    TempDir dir;
    const auto first = dir.write("first.txt", "old first");
    StagedFiles outputs;
    outputs.stage(first, std::string("new first"));
    outputs.stage(dir / "second.txt", std::string("new second"));
    // Now the second target becomes a directory that is not empty: its rename must fail.
    std::filesystem::create_directories(dir / "second.txt" / "inside");
    EXPECT_THROW(outputs.commit(), Error);
    EXPECT_EQ(read_file(first), "old first");
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"first.txt", "second.txt"}));
}

// A process killed while writing leaves its temporary; the next writer into that directory
// removes it when its process is gone, and leaves those of live processes and other hosts.
TEST(AtomicFile, AbandonedTemporariesAreRemovedByTheNextWrite)
{
    TempDir dir;
    // The name this host's temporaries get: made by a write that is made to fail.
    std::string own;
    try {
        write_file_atomically(dir / "probe.txt", [&](std::ofstream&) {
            for (const auto& entry : std::filesystem::directory_iterator(dir.path())) own = entry.path().filename();
            throw Error("probe", "stop");
        });
    } catch (const Error&) {
    }
    const std::size_t marker = own.find(".tmp-");
    ASSERT_NE(marker, std::string::npos) << own;
    const std::string host = own.substr(marker + 5, own.rfind('-', own.rfind('-') - 1) - marker - 5);

    // In a fresh directory (the first write of a process into a directory cleans it).
    TempDir other;
    const std::string dead = "out.pcd.tmp-" + host + "-999999999-0123456789abcdef";
    const std::string dead_kept = dead + ".old";
    const std::string live = "out.pcd.tmp-" + host + "-1-0123456789abcdef";  // pid 1 is always there
    const std::string foreign = "out.pcd.tmp-elsewhere_" + host + "-999999999-0123456789abcdef";
    const std::string unrelated = "notes.tmp-something";
    for (const std::string& name : {dead, dead_kept, live, foreign, unrelated}) other.write(name, "x");
    write_cloud(other / "out.pcd", random_cloud(5, false, false, 3));
    std::vector<std::string> expected{unrelated, "out.pcd", foreign, live};
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(files_in(other.path()), expected);
}

// Failure injection: a writer killed mid-write (SIGKILL, nothing of ours runs), and a disk that
// fills up (the file size limit makes write() fail with EFBIG, as ENOSPC would).
TEST(AtomicFile, KilledWriterLeavesTheOldFileAndItsTemporaryGoesNextRun)
{
    TempDir dir;
    const auto path = dir.write("cloud.pcd", "old contents");
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        write_file_atomically(path, [](std::ofstream& out) {
            out << std::string(100000, 'x');
            out.flush();
            raise(SIGKILL);
        });
        _exit(0);  // not reached
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
    EXPECT_EQ(read_file(path), "old contents");
    ASSERT_EQ(files_in(dir.path()).size(), 2u);  // the target and the dead writer's temporary
    write_cloud(dir / "other.pcd", random_cloud(5, false, false, 1));
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"cloud.pcd", "other.pcd"}));
    EXPECT_EQ(read_file(path), "old contents");
}

TEST(AtomicFile, FullDiskLeavesTheOldFileAndNoTemporary)
{
    TempDir dir;
    const auto path = dir.write("cloud.pcd", "old contents");
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        signal(SIGXFSZ, SIG_IGN);
        const rlimit limit{4096, 4096};
        setrlimit(RLIMIT_FSIZE, &limit);
        try {
            write_cloud(path, random_cloud(5000, true, true, 2));
        } catch (const Error& error) {
            const std::string message = error.what();
            _exit(message.find("failed (disk full?)") != std::string::npos ? 0 : 2);
        }
        _exit(3);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << "2: another error, 3: no error";
    EXPECT_EQ(read_file(path), "old contents");
    EXPECT_EQ(files_in(dir.path()), std::vector<std::string>{"cloud.pcd"});
}

}  // namespace
}  // namespace mfpc
