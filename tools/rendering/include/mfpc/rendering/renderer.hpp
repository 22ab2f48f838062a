#pragma once

/// @file
/// @brief Pictures of a cloud as in the paper's Figures 8 to 10: the points as shaded discs,
/// coloured by the (structure, level) region they fall in, the level boxes as wireframes, and
/// recognised instances on top in red.
///
/// Ray cast on the CPU with Embree; no display and no GPU. Clouds are taken to be in a sensor's
/// camera frame (x right, y down, z forward, the sensor at the origin), as Kinect and PCL clouds
/// are.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/rendering/png_image.hpp"

namespace mfpc {

/// @brief Where a picture is taken from.
enum class ViewKind {
    camera,  ///< The sensor's own view: a pinhole at the origin looking along +z.
    top,     ///< From above (the -y side) looking down along +y, far enough to see the whole cloud.
    orbit,   ///< The sensor's view walked around the vertical axis through the cloud's centre.
};

/// @brief A view of the cloud: its kind and, for an orbit, its angle.
struct RenderView {
    ViewKind kind = ViewKind::camera;  ///< The kind of view.
    float orbit_deg = 0.0f;  ///< Orbit only: positive walks the camera to its right around the centre.
};

/// @brief The view named by `text`.
/// @param text "camera", "top" or "orbit:DEG" (DEG a finite number, e.g. orbit:-30).
/// @return The view.
/// @throws mfpc::Error whose where() is "view" for anything else.
RenderView parse_render_view(std::string_view text);
/// @brief The name of a view, as parse_render_view reads it.
/// @param view The view.
/// @return "camera", "top" or "orbit:DEG".
std::string to_string(const RenderView& view);

/// @brief Where a picture is taken from: the ray of pixel (u, v) (pixel centres at integers) leaves
/// `position` along forward + right (u - cx) / fx + down (v - cy) / fy. right, down and forward are
/// orthonormal and right x down = forward, as the sensor's x, y and z axes are.
struct RenderCamera {
    Eigen::Vector3f position = Eigen::Vector3f::Zero();  ///< The eye.
    Eigen::Vector3f right = Eigen::Vector3f::UnitX();    ///< The image's +u direction.
    Eigen::Vector3f down = Eigen::Vector3f::UnitY();     ///< The image's +v direction.
    Eigen::Vector3f forward = Eigen::Vector3f::UnitZ();  ///< The viewing direction.
    Camera intrinsics;  ///< fx, fy, cx, cy and the image size.

    /// @brief Projects a point into the picture.
    /// @param p The point.
    /// @return (u, v, depth along forward) of p; u and v are meaningless for depth <= 0.
    Eigen::Vector3f project(const Point& p) const;
};

/// @brief How render_cloud draws a picture.
struct RenderParams {
    /// Image size; both 0: the source grid of an organized cloud, else 640 x 480. A size other than
    /// the grid's scales the sensor's intrinsics by the smaller of the two ratios: pixels stay square
    /// and the whole view stays in the picture, centred.
    std::uint32_t width = 0;
    std::uint32_t height = 0;  ///< Image height (see width).
    RenderView view;           ///< Where the picture is taken from.
    /// Disc radius in metres; 0: from each point's neighbours (see render_cloud).
    float point_radius = 0.0f;
    Rgb background{255, 255, 255};  ///< Where no disc is hit.
};

/// @brief Points drawn over the cloud, e.g. a model moved by a recognised instance's transform.
struct RenderOverlay {
    std::vector<Point> points;  ///< The points.
    Rgb color{220, 30, 30};     ///< Their colour.
};

/// @brief What render_cloud drew.
struct RenderStats {
    std::size_t points = 0;          ///< Discs of the cloud: one per distinct position (copies drawn once).
    std::size_t overlay_points = 0;  ///< Discs of all overlays.
    std::size_t boxes = 0;           ///< Level boxes drawn (structures x (m + 1)).
    float point_radius = 0.0f;       ///< The median disc radius of the cloud (metres).
};

/// @brief The camera `params.view` gives for `cloud`.
///
///  - camera: at the origin with the intrinsics fit_camera finds for an organized cloud (scaled to
///    the image size), else fx = 525 (640 / width scaled), fy = 525 (480 / height scaled) and the
///    principal point at the image centre;
///  - orbit:DEG: that camera turned by DEG about the vertical (y) axis through the centre of the
///    cloud's bounding box, at the same distance from it (orbit:0 is the camera view exactly);
///  - top: the same focal lengths, the principal point at the image centre, above the bounding box's
///    centre looking along +y with x to the right and far (+z) at the top, as close as lets the
///    whole bounding box in with a 5% margin.
/// @param cloud The cloud.
/// @param params The view and the image size.
/// @return The camera render_cloud takes the picture with.
/// @throws mfpc::Error for an empty cloud or a bad size (one of width and height 0, over 16384).
RenderCamera render_camera(const PointCloud& cloud, const RenderParams& params);

/// @brief Renders the cloud.
///
///  - Discs: oriented by the cloud's normals when it has them (points with a non-finite normal and
///    clouds without normals get discs facing the ray). The radius, unless params.point_radius is
///    given, is 0.8 of the point's spacing: on an organized cloud the larger of its distances to the
///    nearest grid neighbour along the row and along the column, elsewhere the distance to its 4th
///    nearest point. The spacing is kept within 0.5x and 4x the sensor's pixel footprint at the
///    point's depth (organized clouds whose camera fits) or the median spacing (other clouds), so
///    that stray points do not blot the picture. Overlays are sized the same way from their points.
///  - Shading: Lambert with a light at the eye plus ambient light. Normals come from the cloud, else
///    (organized clouds) from the grid neighbours; unorganized clouds without normals are flat.
///  - Colours: with a foveation config, each point's region (structure, level) under redundancy
///    treatment (the densest level of any structure covering it: smallest d_k, then higher k, then
///    lower structure index) gives region_color; points outside every structure are grey. Without a
///    config, the cloud's rgb when it has colours, else grey.
///  - Boxes: with a config, the 12 edges of every level box k = 0..m of every structure, in the
///    structure's colour, about 1.5 pixels wide; edges hidden behind points are drawn faintly.
///  - Overlays: flat discs in their colour, sized from their own spacing, drawn over the cloud where
///    they lie at or just behind its surface (so an instance sitting on the scene's points shows).
///
/// Deterministic: the same input gives the same image with any thread count.
/// @param cloud The cloud.
/// @param fovea When given, the foveation config whose regions colour the points and whose level
/// boxes are drawn.
/// @param overlays Points drawn over the cloud.
/// @param params The view, the image size, the disc radius and the background.
/// @param stats When given, receives what was drawn.
/// @return The picture, of the size render_camera gives.
/// @throws mfpc::Error for a cloud check_cloud refuses or without points, a point radius that is
/// not a finite number >= 0, a bad size (as render_camera), an overlay point that is not finite, a
/// structure that is not valid (FoveatedStructure::level_box), or an error Embree reports.
RgbImage render_cloud(const PointCloud& cloud, const FoveationConfig* fovea, std::span<const RenderOverlay> overlays,
                      const RenderParams& params, RenderStats* stats = nullptr);

/// @brief The colour of region (structure, level) of a structure with m levels: a hue per structure
/// (red is left for overlays), brighter towards the fovea (level m brightest).
/// @param structure The structure's index.
/// @param level The level k.
/// @param levels m.
/// @return The colour; outside_color for a negative structure or level.
Rgb region_color(int structure, int level, int levels);
/// @brief The colour of a structure's box edges (its hue, fully saturated).
/// @param structure The structure's index.
/// @return The colour.
Rgb structure_color(int structure);
/// @brief Points outside every structure, and every point of a cloud without colours or config.
inline constexpr Rgb outside_color{165, 165, 165};

}  // namespace mfpc
