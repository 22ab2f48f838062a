// Over 600 lines on purpose: one pipeline from a cloud to a picture (the view's camera, disc sizes
// and normals from the cloud's grid or its neighbours, region colours, the Embree scene of discs,
// shading, wireframe boxes and overlays), each step used by this file alone; split by step, the
// parts would only pass the same few structs between them.

#include "mfpc/rendering/renderer.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/rendering/detail/embree_handles.hpp"
#include "mfpc/core/box.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/distinct_points.hpp"
#include "mfpc/index/neighbor_grid.hpp"

namespace mfpc {

namespace {

constexpr float nan_value = std::numeric_limits<float>::quiet_NaN();
constexpr float infinity = std::numeric_limits<float>::infinity();
constexpr std::uint32_t max_image_side = 16384;

// Lambert with a light at the eye: facing surfaces keep their colour, grazing ones fall to the
// ambient share, which is high enough that the region colours stay recognisable.
constexpr float ambient = 0.35f;
// Box edges behind a surface are still drawn, at this opacity, so a box inside the scene reads as
// a box and not as loose segments.
constexpr float hidden_edge_opacity = 0.3f;
constexpr float edge_width_px = 1.5f;
// Discs are this fraction of the point spacing in radius: 0.8 covers a square grid (which needs
// 1/sqrt(2) = 0.71) with a little overlap and without fattening edges much.
constexpr float radius_per_spacing = 0.8f;

using embree::Geometry;

// ---- colours -----------------------------------------------------------------------------------

Rgb from_hsv(float hue_deg, float saturation, float value)
{
    const float h = std::fmod(hue_deg, 360.0f) / 60.0f;
    const int sector = int(h);
    const float f = h - float(sector);
    const float p = value * (1.0f - saturation);
    const float q = value * (1.0f - saturation * f);
    const float t = value * (1.0f - saturation * (1.0f - f));
    float r = value, g = t, b = p;
    switch (sector) {
        case 0: r = value, g = t, b = p; break;
        case 1: r = q, g = value, b = p; break;
        case 2: r = p, g = value, b = t; break;
        case 3: r = p, g = q, b = value; break;
        case 4: r = t, g = p, b = value; break;
        default: r = value, g = p, b = q; break;
    }
    auto byte = [](float c) { return std::uint8_t(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f)); };
    return {byte(r), byte(g), byte(b)};
}

// Hues far from red (kept for overlays) and from each other for the first few structures.
float structure_hue(int structure)
{
    static constexpr std::array<float, 8> hues = {215.0f, 125.0f, 35.0f, 280.0f, 180.0f, 55.0f, 320.0f, 95.0f};
    const int count = int(hues.size());
    const int wrapped = ((structure % count) + count) % count;
    return hues[std::size_t(wrapped)];
}

Rgb shade(Rgb color, float intensity)
{
    auto channel = [intensity](std::uint8_t c) {
        return std::uint8_t(std::lround(std::clamp(float(c) * intensity, 0.0f, 255.0f)));
    };
    return {channel(color.r), channel(color.g), channel(color.b)};
}

Rgb blend(Rgb under, Rgb over, float opacity)
{
    auto channel = [opacity](std::uint8_t a, std::uint8_t b) {
        return std::uint8_t(std::lround(float(a) + (float(b) - float(a)) * opacity));
    };
    return {channel(under.r, over.r), channel(under.g, over.g), channel(under.b, over.b)};
}

// ---- labels ------------------------------------------------------------------------------------

// Each point's region under redundancy treatment (Eq. 6): of the structures whose outer box holds
// it, the one whose level there has the smallest d_k, then the higher level, then the lower
// structure index. The level within a structure is FoveatedStructure::level_of's, with the boxes
// computed once instead of per point.
std::vector<RegionLabel> region_labels(std::span<const Point> points, std::span<const FoveatedStructure> structures)
{
    struct Levels {
        std::vector<Box> boxes;
        std::vector<float> densities;
    };
    std::vector<Levels> levels(structures.size());
    for (std::size_t s = 0; s < structures.size(); ++s) {
        for (int k = 0; k <= structures[s].levels; ++k) {
            levels[s].boxes.push_back(structures[s].level_box(k));
            levels[s].densities.push_back(structures[s].density(k));
        }
    }
    std::vector<RegionLabel> labels(points.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            RegionLabel best;
            float best_density = infinity;
            for (std::size_t s = 0; s < levels.size(); ++s) {
                const auto& boxes = levels[s].boxes;
                int level = -1;
                for (int k = int(boxes.size()) - 1; k >= 0; --k) {
                    if (boxes[std::size_t(k)].contains(points[i])) {
                        level = k;
                        break;
                    }
                }
                if (level < 0) continue;
                const float density = levels[s].densities[std::size_t(level)];
                // Structures come in index order, so a tie in both density and level keeps the
                // earlier structure.
                if (best.structure < 0 || density < best_density || (density == best_density && level > best.level)) {
                    best = {std::int16_t(s), std::int16_t(level)};
                    best_density = density;
                }
            }
            labels[i] = best;
        }
    });
    return labels;
}

// ---- spacing -----------------------------------------------------------------------------------

float median_of(std::vector<float> values)
{
    if (values.empty()) return nan_value;
    const auto middle = values.begin() + std::ptrdiff_t(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

// Disc radii from each point's own spacing (see render_cloud), and the median radius.
struct Radii {
    std::vector<float> radius;
    float median = 0.0f;
};

// The position -> point map of an organized cloud (-1 where the grid has no point).
std::vector<std::int32_t> grid_map(const PointCloud& cloud)
{
    std::vector<std::int32_t> at(cloud.source_size(), -1);
    for (std::size_t i = 0; i < cloud.size(); ++i) at[cloud.source_position(i)] = std::int32_t(i);
    return at;
}

// The spacing of each point of an organized cloud from its grid neighbours: the larger of the
// nearest along the row and the nearest along the column, so that a surface seen at a slant (wide
// spacing one way) is still covered. NaN where a point has no grid neighbour.
std::vector<float> grid_spacing(const PointCloud& cloud, const std::vector<std::int32_t>& at)
{
    std::vector<float> spacing(cloud.size(), nan_value);
    const std::int64_t width = cloud.width, height = cloud.height;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            const std::int64_t position = cloud.source_position(i);
            const std::int64_t u = position % width, v = position / width;
            auto distance_to = [&](std::int64_t du, std::int64_t dv) {
                const std::int64_t nu = u + du, nv = v + dv;
                if (nu < 0 || nv < 0 || nu >= width || nv >= height) return infinity;
                const std::int32_t j = at[std::size_t(nv * width + nu)];
                return j < 0 ? infinity : (cloud.points[std::size_t(j)] - cloud.points[i]).norm();
            };
            const float along_row = std::min(distance_to(-1, 0), distance_to(1, 0));
            const float along_column = std::min(distance_to(0, -1), distance_to(0, 1));
            if (std::isfinite(along_row) && std::isfinite(along_column))
                spacing[i] = std::max(along_row, along_column);
            else if (std::isfinite(along_row))
                spacing[i] = along_row;
            else if (std::isfinite(along_column))
                spacing[i] = along_column;
        }
    });
    return spacing;
}

// The distance from each point to its 4th nearest other point: on a grid, the larger of the two
// spacings, as grid_spacing gives; elsewhere a local spacing that isolated pairs do not shrink.
std::vector<float> neighbour_spacing(std::span<const Point> points)
{
    std::vector<float> spacing(points.size(), nan_value);
    if (points.size() < 2) return spacing;
    // The grid only needs a cell of a few spacings for speed (the search is exact for any cell):
    // guess the spacing as that of a surface of half the bounding box's area.
    const Eigen::Vector3f size = bounding_box(points).size();
    const double area = double(size.x()) * size.y() + double(size.y()) * size.z() + double(size.z()) * size.x();
    const float guess = float(std::sqrt(std::max(area, 1e-12) / double(points.size())));
    const NeighborGrid grid(points, std::max(3.0f * guess, 1e-4f));
    const int k = int(std::min<std::size_t>(5, points.size()));
    std::vector<std::uint32_t> indices(points.size() * std::size_t(k));
    std::vector<float> squared(indices.size());
    grid.knn_search_batch(points, k, indices, squared);
    for (std::size_t i = 0; i < points.size(); ++i) spacing[i] = std::sqrt(squared[i * std::size_t(k) + std::size_t(k - 1)]);
    return spacing;
}

// neighbour_spacing with each position searched once (copies of a point would make the search
// quadratic); a copy takes the spacing of the first point at its position.
std::vector<float> distinct_spacing(std::span<const Point> points)
{
    const DistinctPoints distinct = distinct_points(points);
    if (distinct.all_distinct()) return neighbour_spacing(points);
    const std::vector<std::uint32_t> heads = distinct.representatives(points.size());
    std::vector<Point> positions;
    positions.reserve(heads.size());
    for (std::uint32_t h : heads) positions.push_back(points[h]);
    const std::vector<float> head_spacing = neighbour_spacing(positions);
    std::vector<float> spacing(points.size());
    std::vector<std::uint32_t> slot(points.size(), 0);
    for (std::size_t i = 0; i < heads.size(); ++i) slot[heads[i]] = std::uint32_t(i);
    for (std::size_t i = 0; i < points.size(); ++i) spacing[i] = head_spacing[slot[distinct.first[i]]];
    return spacing;
}

// Radius = radius_per_spacing x spacing, the spacing kept within [0.5, 4] x a reference so that
// stray points (a lone outlier, a flying pixel between two surfaces) do not blot the picture. The
// reference is per point when given (the sensor's pixel footprint at the point's depth: the floor
// of a far room is sampled ten times more sparsely than a near object, legitimately), else the
// median spacing.
Radii disc_radii(std::vector<float> spacing, const std::vector<float>* reference = nullptr)
{
    Radii radii;
    std::vector<float> known;
    known.reserve(spacing.size());
    for (float s : spacing) {
        if (std::isfinite(s) && s > 0.0f) known.push_back(s);
    }
    float median = median_of(std::move(known));
    // A single point, or only duplicates: nothing to measure, so a size that shows a point at a
    // metre or two.
    if (!(median > 0.0f)) median = 0.005f;
    radii.radius.resize(spacing.size());
    for (std::size_t i = 0; i < spacing.size(); ++i) {
        const float typical = reference != nullptr ? (*reference)[i] : median;
        const float s = std::isfinite(spacing[i]) ? std::clamp(spacing[i], 0.5f * typical, 4.0f * typical) : typical;
        radii.radius[i] = radius_per_spacing * s;
    }
    // The median radius actually used (for stats and depth tolerances).
    radii.median = median_of(radii.radius);
    return radii;
}

Radii fixed_radii(std::size_t count, float radius)
{
    Radii radii;
    radii.radius.assign(count, radius);
    radii.median = radius;
    return radii;
}

// Radii for the cloud: from the grid when it is organized and most points have grid neighbours
// (a foveated, downsampled cloud keeps its grid size but few neighbours), else from the points.
Radii cloud_radii(const PointCloud& cloud, const std::vector<std::int32_t>* at, const std::optional<Camera>& sensor)
{
    if (at != nullptr) {
        std::vector<float> spacing = grid_spacing(cloud, *at);
        const auto known = std::count_if(spacing.begin(), spacing.end(), [](float s) { return std::isfinite(s); });
        if (std::size_t(known) * 2 >= spacing.size()) {
            if (!sensor) return disc_radii(std::move(spacing));
            // A pixel's footprint at depth z is z / f.
            std::vector<float> footprint(cloud.size());
            const float inverse_focal = 2.0f / (sensor->fx + sensor->fy);
            for (std::size_t i = 0; i < cloud.size(); ++i) footprint[i] = cloud.points[i].z() * inverse_focal;
            return disc_radii(std::move(spacing), &footprint);
        }
    }
    return disc_radii(neighbour_spacing(cloud.points));
}

// Shading normals of an organized cloud without normals: the cross product of the row and column
// differences across each point's grid neighbours (one-sided at a missing neighbour). Neighbours
// farther than a few disc radii per pixel lie across a depth jump and are left out. NaN where no plane is
// spanned.
std::vector<Point> grid_normals(const PointCloud& cloud, const std::vector<std::int32_t>& at,
                                const std::vector<float>& radius)
{
    std::vector<Point> normals(cloud.size(), Point::Constant(nan_value));
    const std::int64_t width = cloud.width, height = cloud.height;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            const Point& p = cloud.points[i];
            const float reach = 4.0f * radius[i];
            const std::int64_t position = cloud.source_position(i);
            const std::int64_t u = position % width, v = position / width;
            // Two pixels out where possible: Kinect depth is quantised, and differences over one
            // pixel make a flat wall look hammered.
            auto neighbour = [&](std::int64_t du, std::int64_t dv) -> const Point& {
                for (std::int64_t step = 2; step >= 1; --step) {
                    const std::int64_t nu = u + step * du, nv = v + step * dv;
                    if (nu < 0 || nv < 0 || nu >= width || nv >= height) continue;
                    const std::int32_t j = at[std::size_t(nv * width + nu)];
                    if (j < 0) continue;
                    const Point& q = cloud.points[std::size_t(j)];
                    if ((q - p).norm() <= float(step) * reach) return q;
                }
                return p;
            };
            const Point along_row = neighbour(1, 0) - neighbour(-1, 0);
            const Point along_column = neighbour(0, 1) - neighbour(0, -1);
            const Point normal = along_row.cross(along_column);
            const float length = normal.norm();
            if (length > 0.0f && std::isfinite(length)) normals[i] = normal / length;
        }
    });
    return normals;
}

// ---- camera ------------------------------------------------------------------------------------

void check_size(const RenderParams& params)
{
    if ((params.width == 0) != (params.height == 0)) {
        throw Error("render", "give both width and height, or neither (got " + std::to_string(params.width) + "x" +
                                  std::to_string(params.height) + ")");
    }
    if (params.width > max_image_side || params.height > max_image_side) {
        throw Error("render", "image size " + std::to_string(params.width) + "x" + std::to_string(params.height) +
                                  " is over the limit of " + std::to_string(max_image_side) + " a side");
    }
}

// The sensor's intrinsics at the requested image size; `fitted` is fit_camera(cloud) for an
// organized cloud.
Camera sensor_intrinsics(const PointCloud& cloud, const std::optional<Camera>& fitted, const RenderParams& params)
{
    Camera camera;  // the Kinect's 525 px at 640 x 480, principal point at the centre
    camera.cx = 0.5f * float(camera.width - 1);
    camera.cy = 0.5f * float(camera.height - 1);
    if (cloud.organized()) {
        if (fitted) {
            camera = *fitted;
        } else {
            // A grid that is no pinhole image: the Kinect's field of view over its size.
            camera.fx = 525.0f * float(cloud.width) / 640.0f;
            camera.fy = 525.0f * float(cloud.height) / 480.0f;
            camera.cx = 0.5f * float(cloud.width - 1);
            camera.cy = 0.5f * float(cloud.height - 1);
            camera.width = cloud.width;
            camera.height = cloud.height;
        }
    }
    if (params.width == 0 || (params.width == camera.width && params.height == camera.height)) return camera;
    // Another resolution: one scale for both axes keeps pixels square, the smaller one keeps the
    // whole original view in the picture, and the principal point moves with the image centre.
    // Pixel centres sit at integers, so the edges of the image (at -0.5 and width - 0.5) are what scale.
    const float sx = float(params.width) / float(camera.width);
    const float sy = float(params.height) / float(camera.height);
    const float scale = std::min(sx, sy);
    camera.fx *= scale;
    camera.fy *= scale;
    camera.cx = (camera.cx + 0.5f) * scale - 0.5f + 0.5f * (float(params.width) - scale * float(camera.width));
    camera.cy = (camera.cy + 0.5f) * scale - 0.5f + 0.5f * (float(params.height) - scale * float(camera.height));
    camera.width = params.width;
    camera.height = params.height;
    camera.max_residual = 0.0f;
    return camera;
}

RenderCamera view_camera(const PointCloud& cloud, const std::optional<Camera>& fitted, const RenderParams& params);

}  // namespace

// ---- public ------------------------------------------------------------------------------------

RenderView parse_render_view(std::string_view text)
{
    const std::string quoted = "'" + std::string(text) + "'";
    if (text == "camera") return {ViewKind::camera, 0.0f};
    if (text == "top") return {ViewKind::top, 0.0f};
    constexpr std::string_view orbit = "orbit:";
    if (text.substr(0, orbit.size()) == orbit) {
        const std::string_view number = text.substr(orbit.size());
        float degrees = 0.0f;
        const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), degrees);
        if (number.empty() || error != std::errc() || end != number.data() + number.size() || !std::isfinite(degrees)) {
            throw Error("view", quoted + ": orbit needs a number of degrees, e.g. orbit:30");
        }
        return {ViewKind::orbit, degrees};
    }
    throw Error("view", quoted + " is not camera, top or orbit:DEG");
}

std::string to_string(const RenderView& view)
{
    switch (view.kind) {
        case ViewKind::camera: return "camera";
        case ViewKind::top: return "top";
        case ViewKind::orbit: {
            char buffer[48];
            std::snprintf(buffer, sizeof buffer, "orbit:%g", double(view.orbit_deg));
            return buffer;
        }
    }
    return "camera";
}

Eigen::Vector3f RenderCamera::project(const Point& p) const
{
    const Eigen::Vector3f q = p - position;
    const float depth = forward.dot(q);
    return {intrinsics.fx * right.dot(q) / depth + intrinsics.cx, intrinsics.fy * down.dot(q) / depth + intrinsics.cy,
            depth};
}

RenderCamera render_camera(const PointCloud& cloud, const RenderParams& params)
{
    if (cloud.empty()) throw Error("render", "the cloud is empty");
    check_size(params);
    return view_camera(cloud, cloud.organized() ? fit_camera(cloud) : std::nullopt, params);
}

namespace {

RenderCamera view_camera(const PointCloud& cloud, const std::optional<Camera>& fitted, const RenderParams& params)
{
    RenderCamera camera;
    camera.intrinsics = sensor_intrinsics(cloud, fitted, params);
    // orbit:0 is the camera view bit for bit: rotating by a zero angle would still turn +0 into -0
    // in a direction, which changes Embree's reciprocal directions.
    if (params.view.kind == ViewKind::camera || (params.view.kind == ViewKind::orbit && params.view.orbit_deg == 0.0f))
        return camera;

    const Box bounds = bounding_box(cloud.points);
    const Eigen::Vector3f center = bounds.center();
    if (params.view.kind == ViewKind::orbit) {
        // Turning about the y axis: the camera walks to its right (+x) for a positive angle.
        const double angle = double(params.view.orbit_deg) * std::numbers::pi / 180.0;
        const float c = float(std::cos(angle)), s = float(std::sin(angle));
        Eigen::Matrix3f turn;
        turn << c, 0.0f, -s, 0.0f, 1.0f, 0.0f, s, 0.0f, c;
        camera.position = center + turn * (Eigen::Vector3f::Zero() - center);
        camera.right = turn.col(0);
        camera.down = Eigen::Vector3f::UnitY();
        camera.forward = turn.col(2);
        return camera;
    }

    // Top: looking down (+y, since y points down), x to the right, far (+z) at the top.
    Camera& intrinsics = camera.intrinsics;
    intrinsics.cx = 0.5f * float(intrinsics.width - 1);
    intrinsics.cy = 0.5f * float(intrinsics.height - 1);
    camera.right = Eigen::Vector3f::UnitX();
    camera.down = -Eigen::Vector3f::UnitZ();
    camera.forward = Eigen::Vector3f::UnitY();
    const Eigen::Vector3f half = 0.5f * bounds.size();
    // The box's near face must fit in 90% of the image (5% margin each side): distance to that face
    // = half extent x focal length / (45% of the image).
    const float to_near_face = std::max({intrinsics.fx * half.x() / (0.45f * float(intrinsics.width)),
                                         intrinsics.fy * half.z() / (0.45f * float(intrinsics.height)), 0.01f});
    camera.position = center - (half.y() + to_near_face) * camera.forward;
    return camera;
}

}  // namespace

Rgb region_color(int structure, int level, int levels)
{
    if (structure < 0 || level < 0) return outside_color;
    const float t = levels > 0 ? std::clamp(float(level) / float(levels), 0.0f, 1.0f) : 1.0f;
    // Level 0 dark and muted, the fovea bright and saturated.
    return from_hsv(structure_hue(structure), 0.55f + 0.35f * t, 0.45f + 0.55f * t);
}

Rgb structure_color(int structure) { return from_hsv(structure_hue(structure), 1.0f, 0.8f); }

RgbImage render_cloud(const PointCloud& input, const FoveationConfig* fovea, std::span<const RenderOverlay> overlays,
                      const RenderParams& params, RenderStats* stats)
{
    check_cloud(input, "render");
    // Copies of one point draw the same disc, and the neighbour searches that size the discs would
    // pay m x m for m of them: draw each position once.
    const DistinctPoints distinct = distinct_points(input.points);
    const PointCloud distinct_cloud =
        distinct.all_distinct() ? PointCloud{} : select(input, distinct.representatives(input.size()));
    const PointCloud& cloud = distinct.all_distinct() ? input : distinct_cloud;
    if (!(params.point_radius >= 0.0f) || !std::isfinite(params.point_radius)) {
        throw Error("render", "point radius must be a finite number >= 0, got " + format_number(params.point_radius));
    }
    if (cloud.empty()) throw Error("render", "the cloud is empty");
    check_size(params);
    const std::optional<Camera> sensor = cloud.organized() ? fit_camera(cloud) : std::nullopt;
    const RenderCamera camera = view_camera(cloud, sensor, params);
    const std::uint32_t width = camera.intrinsics.width, height = camera.intrinsics.height;

    // Per-point attributes: radius, colour, shading normal (NaN: none).
    std::vector<std::int32_t> at;
    if (cloud.organized()) at = grid_map(cloud);
    const Radii radii = params.point_radius > 0.0f ? fixed_radii(cloud.size(), params.point_radius)
                                                   : cloud_radii(cloud, cloud.organized() ? &at : nullptr, sensor);
    std::vector<Rgb> colors(cloud.size(), outside_color);
    const bool boxes_drawn = fovea != nullptr && !fovea->structures.empty();
    if (boxes_drawn) {
        const std::vector<RegionLabel> labels = region_labels(cloud.points, fovea->structures);
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            const RegionLabel label = labels[i];
            if (label.structure >= 0) {
                colors[i] = region_color(label.structure, label.level,
                                         fovea->structures[std::size_t(label.structure)].levels);
            }
        }
    } else if (cloud.has_colors()) {
        colors = cloud.colors;
    }
    std::vector<Point> shading_normals;
    if (!cloud.has_normals() && cloud.organized()) shading_normals = grid_normals(cloud, at, radii.radius);

    const embree::Device device = embree::make_device();

    // The cloud: oriented discs where a normal is known, discs facing the ray elsewhere.
    const embree::Scene cloud_scene = embree::make_scene(device.get());
    std::array<std::vector<std::uint32_t>, 2> point_of;  // per geometry id: primitive -> point
    for (std::uint32_t i = 0; i < cloud.size(); ++i) {
        const bool oriented = cloud.has_normals() && cloud.normals[i].allFinite() && cloud.normals[i].norm() > 0.0f;
        point_of[oriented ? 0 : 1].push_back(i);
    }
    auto add_discs = [&](RTCScene scene, RTCGeometryType type, std::span<const Point> points,
                         std::span<const std::uint32_t> chosen, std::span<const float> radius,
                         std::span<const Point> normals) -> unsigned {
        Geometry geometry(rtcNewGeometry(device.get(), type));
        embree::check(device.get(), "disc geometry");
        auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0,
                                                                     RTC_FORMAT_FLOAT4, 4 * sizeof(float),
                                                                     chosen.size()));
        embree::check(device.get(), "disc vertices");
        for (std::size_t j = 0; j < chosen.size(); ++j) {
            const Point& p = points[chosen[j]];
            vertices[4 * j + 0] = p.x();
            vertices[4 * j + 1] = p.y();
            vertices[4 * j + 2] = p.z();
            vertices[4 * j + 3] = radius[chosen[j]];
        }
        if (type == RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT) {
            auto* out = static_cast<float*>(rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_NORMAL, 0,
                                                                    RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                                    chosen.size()));
            embree::check(device.get(), "disc normals");
            for (std::size_t j = 0; j < chosen.size(); ++j) {
                const Point n = normals[chosen[j]].normalized();
                out[3 * j + 0] = n.x();
                out[3 * j + 1] = n.y();
                out[3 * j + 2] = n.z();
            }
        }
        rtcCommitGeometry(geometry.get());
        const unsigned id = rtcAttachGeometry(scene, geometry.get());
        embree::check(device.get(), "disc geometry");
        return id;
    };
    // Geometry ids follow attachment order from 0; geometries without primitives are not made, so
    // each id is mapped to its point list explicitly.
    std::vector<int> list_of_geometry;
    for (int list = 0; list < 2; ++list) {
        if (point_of[std::size_t(list)].empty()) continue;
        const unsigned id = add_discs(cloud_scene.get(),
                                      list == 0 ? RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT : RTC_GEOMETRY_TYPE_DISC_POINT,
                                      cloud.points, point_of[std::size_t(list)], radii.radius, cloud.normals);
        if (list_of_geometry.size() <= id) list_of_geometry.resize(id + 1, -1);
        list_of_geometry[id] = list;
    }
    rtcCommitScene(cloud_scene.get());
    embree::check(device.get(), "cloud scene");

    // Overlays: discs facing the ray, sized by each overlay's own spacing.
    const embree::Scene overlay_scene = embree::make_scene(device.get());
    std::vector<Rgb> overlay_color_of_geometry;
    float overlay_radius = 0.0f;  // the largest median, for the depth tolerance
    std::size_t overlay_points = 0;
    for (const RenderOverlay& overlay : overlays) {
        if (overlay.points.empty()) continue;
        for (const Point& p : overlay.points) {
            if (!within_coordinate_range(p)) {
                throw Error("render", std::string("an overlay has a point not finite or beyond ±") + max_coordinate_text);
            }
        }
        const Radii overlay_radii = params.point_radius > 0.0f ? fixed_radii(overlay.points.size(), params.point_radius)
                                                               : disc_radii(distinct_spacing(overlay.points));
        std::vector<std::uint32_t> all(overlay.points.size());
        for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
        const unsigned id = add_discs(overlay_scene.get(), RTC_GEOMETRY_TYPE_DISC_POINT, overlay.points, all,
                                      overlay_radii.radius, {});
        if (overlay_color_of_geometry.size() <= id) overlay_color_of_geometry.resize(id + 1);
        overlay_color_of_geometry[id] = overlay.color;
        overlay_radius = std::max(overlay_radius, overlay_radii.median);
        overlay_points += overlay.points.size();
    }
    rtcCommitScene(overlay_scene.get());
    embree::check(device.get(), "overlay scene");
    // An overlay point lying on the cloud's surface may sit a little behind the cloud's disc there
    // (sensor noise, the instance's residual pose error): it still shows within this depth.
    const float overlay_tolerance = 4.0f * (overlay_radius + radii.median);

    // Level boxes: 12 edges each, as ribbons facing the ray about edge_width_px wide at their depth.
    const embree::Scene box_scene = embree::make_scene(device.get());
    std::vector<int> structure_of_segment;
    std::size_t boxes = 0;
    if (boxes_drawn) {
        std::vector<std::array<float, 4>> vertices;
        const float focal = 0.5f * (camera.intrinsics.fx + camera.intrinsics.fy);
        const float near_depth = 1e-3f;
        auto add_edge = [&](Point a, Point b, int structure) {
            float depth_a = camera.forward.dot(a - camera.position);
            float depth_b = camera.forward.dot(b - camera.position);
            if (depth_a < near_depth && depth_b < near_depth) return;
            // An edge passing behind the eye is cut at a plane just in front of it: a ribbon's
            // width grows with depth and cannot go negative.
            if (depth_a < near_depth) {
                a = a + (b - a) * ((near_depth - depth_a) / (depth_b - depth_a));
                depth_a = near_depth;
            } else if (depth_b < near_depth) {
                b = b + (a - b) * ((near_depth - depth_b) / (depth_a - depth_b));
                depth_b = near_depth;
            }
            const float half_width_a = 0.5f * edge_width_px * depth_a / focal;
            const float half_width_b = 0.5f * edge_width_px * depth_b / focal;
            vertices.push_back({a.x(), a.y(), a.z(), half_width_a});
            vertices.push_back({b.x(), b.y(), b.z(), half_width_b});
            structure_of_segment.push_back(structure);
        };
        for (std::size_t s = 0; s < fovea->structures.size(); ++s) {
            const FoveatedStructure& structure = fovea->structures[s];
            for (int level = 0; level <= structure.levels; ++level) {
                const Box box = structure.level_box(level);
                ++boxes;
                auto corner = [&box](int i) {
                    return Point((i & 1) ? box.max.x() : box.min.x(), (i & 2) ? box.max.y() : box.min.y(),
                                 (i & 4) ? box.max.z() : box.min.z());
                };
                // Corners differing in one bit of their number share an edge.
                for (int i = 0; i < 8; ++i) {
                    for (int bit = 1; bit < 8; bit <<= 1) {
                        if ((i & bit) == 0) add_edge(corner(i), corner(i | bit), int(s));
                    }
                }
            }
        }
        if (!structure_of_segment.empty()) {
            Geometry geometry(rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_FLAT_LINEAR_CURVE));
            embree::check(device.get(), "edge geometry");
            auto* out = static_cast<float*>(rtcSetNewGeometryBuffer(
                geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), vertices.size()));
            embree::check(device.get(), "edge vertices");
            for (std::size_t j = 0; j < vertices.size(); ++j) std::copy(vertices[j].begin(), vertices[j].end(), out + 4 * j);
            auto* index = static_cast<std::uint32_t*>(rtcSetNewGeometryBuffer(
                geometry.get(), RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(std::uint32_t),
                structure_of_segment.size()));
            embree::check(device.get(), "edge segments");
            for (std::uint32_t j = 0; j < structure_of_segment.size(); ++j) index[j] = 2 * j;
            rtcCommitGeometry(geometry.get());
            rtcAttachGeometry(box_scene.get(), geometry.get());
            embree::check(device.get(), "edge geometry");
        }
    }
    rtcCommitScene(box_scene.get());
    embree::check(device.get(), "box scene");

    RgbImage image;
    image.width = width;
    image.height = height;
    image.pixels.resize(std::size_t(width) * height * 3);
    const Camera& k = camera.intrinsics;
    const bool any_overlay = overlay_points > 0;
    const bool any_edge = !structure_of_segment.empty();
    std::vector<Rgb> edge_colors;
    if (boxes_drawn) {
        for (std::size_t s = 0; s < fovea->structures.size(); ++s) edge_colors.push_back(structure_color(int(s)));
    }
    // Every pixel is computed on its own from the committed scenes, so the split into row blocks
    // cannot change the image.
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, height, 4), [&](const tbb::blocked_range<std::uint32_t>& rows) {
        RTCIntersectContext context;
        for (std::uint32_t v = rows.begin(); v < rows.end(); ++v) {
            for (std::uint32_t u = 0; u < width; ++u) {
                const Eigen::Vector3f direction = (camera.forward + camera.right * ((float(u) - k.cx) / k.fx) +
                                                   camera.down * ((float(v) - k.cy) / k.fy))
                                                      .normalized();
                Rgb color = params.background;
                float surface = infinity;  // metres along the ray to what hides the edges

                rtcInitIntersectContext(&context);
                RTCRayHit hit = embree::make_ray(camera.position.data(), direction.data());
                rtcIntersect1(cloud_scene.get(), &context, &hit);
                if (hit.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                    const int list = list_of_geometry[hit.hit.geomID];
                    const std::uint32_t i = point_of[std::size_t(list)][hit.hit.primID];
                    surface = hit.ray.tfar;
                    Eigen::Vector3f normal = Eigen::Vector3f::Constant(nan_value);
                    if (list == 0)
                        normal = Eigen::Vector3f(hit.hit.Ng_x, hit.hit.Ng_y, hit.hit.Ng_z).normalized();
                    else if (!shading_normals.empty())
                        normal = shading_normals[i];
                    const float lambert = normal.allFinite() ? std::abs(normal.dot(direction)) : 1.0f;
                    color = shade(colors[i], ambient + (1.0f - ambient) * lambert);
                }
                if (any_overlay) {
                    rtcInitIntersectContext(&context);
                    RTCRayHit over = embree::make_ray(camera.position.data(), direction.data());
                    rtcIntersect1(overlay_scene.get(), &context, &over);
                    if (over.hit.geomID != RTC_INVALID_GEOMETRY_ID && over.ray.tfar <= surface + overlay_tolerance) {
                        color = overlay_color_of_geometry[over.hit.geomID];
                        surface = std::min(surface, over.ray.tfar);
                    }
                }
                if (any_edge) {
                    rtcInitIntersectContext(&context);
                    RTCRayHit edge = embree::make_ray(camera.position.data(), direction.data());
                    rtcIntersect1(box_scene.get(), &context, &edge);
                    if (edge.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                        const Rgb edge_color = edge_colors[std::size_t(structure_of_segment[edge.hit.primID])];
                        color = edge.ray.tfar <= surface ? edge_color : blend(color, edge_color, hidden_edge_opacity);
                    }
                }
                std::uint8_t* pixel = image.pixels.data() + (std::size_t(v) * width + u) * 3;
                pixel[0] = color.r;
                pixel[1] = color.g;
                pixel[2] = color.b;
            }
        }
    });

    if (stats != nullptr) {
        stats->points = cloud.size();
        stats->overlay_points = overlay_points;
        stats->boxes = boxes;
        stats->point_radius = radii.median;
    }
    return image;
}

}  // namespace mfpc
