// The built-in household objects, built from a few shapes: surfaces of revolution (bottle, mug
// body, caps), lofts through cross-sections (carton, box, jug body) and torus segments (handles).
// Every component is a closed, outward-wound mesh; an object with a handle or a cap is several
// components that overlap where they join, which a ray caster and the surface sampler both take
// as they are. Sizes follow real objects in metres, because recognition radii and densities are
// set in metres.

#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "mfpc/core/error.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace mfpc {

namespace {

using Vec = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;
using Ring = std::vector<Vec>;

constexpr double pi = std::numbers::pi;

int add_vertex(TriangleMesh& mesh, const Vec& point)
{
    mesh.vertices.push_back(point.cast<float>());
    return static_cast<int>(mesh.vertices.size()) - 1;
}

void add_triangle(TriangleMesh& mesh, int a, int b, int c)
{
    mesh.triangles.emplace_back(a, b, c);
}

// Appends `part` as a component of its own (its vertices are copied, not shared).
void append(TriangleMesh& mesh, const TriangleMesh& part)
{
    const int offset = static_cast<int>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (const Eigen::Vector3i& triangle : part.triangles) {
        mesh.triangles.emplace_back(triangle + Eigen::Vector3i::Constant(offset));
    }
}

Vec centroid(const Ring& ring)
{
    Vec sum = Vec::Zero();
    for (const Vec& point : ring) sum += point;
    return sum / static_cast<double>(ring.size());
}

// Closes a ring with a fan of triangles around `centre`. A ring that winds counter-clockwise about
// a direction gets a cap facing along it, or against it when `reversed`. The ring must be
// star-shaped seen from the centre, which every convex cross-section is.
void cap_with_fan(TriangleMesh& mesh, const Vec& centre, int first, int count, bool reversed)
{
    const int hub = add_vertex(mesh, centre);
    for (int j = 0; j < count; ++j) {
        const int here = first + j;
        const int next = first + (j + 1) % count;
        if (reversed) {
            add_triangle(mesh, hub, next, here);
        } else {
            add_triangle(mesh, hub, here, next);
        }
    }
}

// A closed tube through `rings` (all of the same size), capped with fans at `start` and `end`.
// Each ring winds counter-clockwise about the direction towards the next one; then the band
// between two rings faces outward (its normal is the ring's tangent crossed with the step to the
// next ring), the start cap faces back and the end cap forward. Surfaces of revolution also fit:
// there the "direction" turns from outward along the bottom to up the side to inward on top.
TriangleMesh loft(std::span<const Ring> rings, const Vec& start, const Vec& end)
{
    TriangleMesh mesh;
    const int count = static_cast<int>(rings.front().size());
    std::vector<int> first;
    for (const Ring& ring : rings) {
        first.push_back(static_cast<int>(mesh.vertices.size()));
        for (const Vec& point : ring) add_vertex(mesh, point);
    }
    for (std::size_t r = 0; r + 1 < rings.size(); ++r) {
        for (int j = 0; j < count; ++j) {
            const int a0 = first[r] + j;
            const int a1 = first[r] + (j + 1) % count;
            const int b0 = first[r + 1] + j;
            const int b1 = first[r + 1] + (j + 1) % count;
            add_triangle(mesh, a0, a1, b1);
            add_triangle(mesh, a0, b1, b0);
        }
    }
    cap_with_fan(mesh, start, first.front(), count, true);
    cap_with_fan(mesh, end, first.back(), count, false);
    return mesh;
}

// A lofted prism or tube capped at the centroids of its end rings.
TriangleMesh loft_capped(std::span<const Ring> rings)
{
    return loft(rings, centroid(rings.front()), centroid(rings.back()));
}

// The surface swept by a profile of (radius, height) points turning about the z axis through
// `centre`. The profile runs from a point on the axis out along the bottom, up the side and back
// to the axis on top, so that the material is on its left; the end points (radius 0) become the
// tips of the bottom and top caps, every other point a ring of `segments` vertices.
TriangleMesh revolve(std::span<const Vec2> profile, int segments, const Vec& centre = Vec::Zero())
{
    std::vector<Ring> rings;
    for (std::size_t i = 1; i + 1 < profile.size(); ++i) {
        Ring ring;
        for (int k = 0; k < segments; ++k) {
            const double angle = 2.0 * pi * k / segments;
            const double radius = profile[i].x();
            ring.push_back(centre + Vec(radius * std::cos(angle), radius * std::sin(angle), profile[i].y()));
        }
        rings.push_back(std::move(ring));
    }
    return loft(rings, centre + Vec(0.0, 0.0, profile.front().y()), centre + Vec(0.0, 0.0, profile.back().y()));
}

// A bent tube (a piece of a torus), closed with flat caps: its centre line is the arc of radius
// `bend` about `centre` in the plane spanned by `u` (angle 0) and `v` (angle 90 degrees), from angle
// `from` to `to` (radians, from < to), and its cross-section a circle of radius `tube`.
TriangleMesh torus_segment(const Vec& centre, const Vec& u, const Vec& v, double bend, double tube, double from,
                           double to, int steps, int tube_segments)
{
    // v x u completes the right-handed frame (radial, side, tangent), so each cross-section winds
    // counter-clockwise about the direction of travel, as loft() expects.
    const Vec side = v.cross(u);
    std::vector<Ring> rings;
    for (int i = 0; i <= steps; ++i) {
        const double angle = from + (to - from) * i / steps;
        const Vec radial = std::cos(angle) * u + std::sin(angle) * v;
        const Vec middle = centre + bend * radial;
        Ring ring;
        for (int k = 0; k < tube_segments; ++k) {
            const double around = 2.0 * pi * k / tube_segments;
            ring.push_back(middle + tube * (std::cos(around) * radial + std::sin(around) * side));
        }
        rings.push_back(std::move(ring));
    }
    const auto end_of = [&](double angle) { return centre + bend * (std::cos(angle) * u + std::sin(angle) * v); };
    return loft(rings, end_of(from), end_of(to));
}

// Appends `steps` points of a circular arc (the start point excluded, the end point included) to a
// profile: a rounded edge between two straight runs.
void add_arc(std::vector<Vec2>& profile, const Vec2& centre, double radius, double from_degrees, double to_degrees,
             int steps)
{
    for (int i = 1; i <= steps; ++i) {
        const double angle = (from_degrees + (to_degrees - from_degrees) * i / steps) * pi / 180.0;
        profile.push_back(centre + radius * Vec2(std::cos(angle), std::sin(angle)));
    }
}

// A rectangle with rounded corners in the plane z, counter-clockwise seen from above.
Ring rounded_rectangle(double half_x, double half_y, double corner_radius, double z, int corner_steps)
{
    const std::array<Vec2, 4> corners = {Vec2(half_x, half_y), Vec2(-half_x, half_y), Vec2(-half_x, -half_y),
                                         Vec2(half_x, -half_y)};
    Ring ring;
    for (int c = 0; c < 4; ++c) {
        const Vec2 centre = corners[static_cast<std::size_t>(c)] -
                            corner_radius * corners[static_cast<std::size_t>(c)].cwiseSign();
        for (int i = 0; i <= corner_steps; ++i) {
            const double angle = (c + double(i) / corner_steps) * pi / 2.0;
            const Vec2 point = centre + corner_radius * Vec2(std::cos(angle), std::sin(angle));
            ring.emplace_back(point.x(), point.y(), z);
        }
    }
    return ring;
}

// A superellipse |x/a|^4 + |y/b|^4 = 1 scaled by `scale`, in the plane z, counter-clockwise seen
// from above: a rectangle with generously rounded corners, the cross-section of many bottles and jugs.
Ring superellipse(double half_x, double half_y, double scale, double z, int segments)
{
    Ring ring;
    for (int k = 0; k < segments; ++k) {
        const double angle = 2.0 * pi * k / segments;
        const double c = std::cos(angle);
        const double s = std::sin(angle);
        const double x = std::copysign(std::sqrt(std::abs(c)), c);
        const double y = std::copysign(std::sqrt(std::abs(s)), s);
        ring.emplace_back(scale * half_x * x, scale * half_y * y, z);
    }
    return ring;
}

// A 1-litre gable-top milk carton: a 7 x 7 cm body 19.5 cm tall, two roof slopes rising 2.5 cm to
// the ridge, and the sealed fin (1 cm tall, 3 mm thick) along the ridge. The whole carton is one
// prism along y: its cross-section is the body, roof and fin outline, and its two end caps are the
// front and back panels with their triangular gables.
TriangleMesh make_carton()
{
    const double half = 0.035;
    const double body = 0.195;
    const double ridge = 0.22;
    const double fin_half = 0.0015;
    const double fin_top = 0.23;
    const double fin_foot = ridge - fin_half * (ridge - body) / half;  // where the fin leaves a roof slope
    // Counter-clockwise about -y, the direction from the first ring (y = +half) to the second.
    const std::array<Vec2, 8> outline = {Vec2(-half, 0.0),      Vec2(half, 0.0),          Vec2(half, body),
                                         Vec2(fin_half, fin_foot), Vec2(fin_half, fin_top),  Vec2(-fin_half, fin_top),
                                         Vec2(-fin_half, fin_foot), Vec2(-half, body)};
    std::array<Ring, 2> rings;
    for (const Vec2& point : outline) {
        rings[0].emplace_back(point.x(), half, point.y());
        rings[1].emplace_back(point.x(), -half, point.y());
    }
    return loft_capped(rings);
}

// A 25 cm drink bottle: a 3.3 cm radius body with a shallow grip waist, a smooth shoulder into a
// 1.3 cm neck with a support ring, and a slightly wider screw cap.
TriangleMesh make_bottle()
{
    std::vector<Vec2> profile = {Vec2(0.0, 0.0), Vec2(0.030, 0.0)};
    add_arc(profile, Vec2(0.030, 0.003), 0.003, -90.0, 0.0, 3);  // rounded bottom edge
    const double body = 0.033;
    profile.emplace_back(body, 0.06);
    for (int i = 1; i <= 8; ++i) {  // the waist: 1.5 mm deep, 5 cm long
        const double t = i / 8.0;
        profile.emplace_back(body - 0.0015 * 0.5 * (1.0 - std::cos(2.0 * pi * t)), 0.06 + 0.05 * t);
    }
    profile.emplace_back(body, 0.15);
    const double neck = 0.013;
    for (int i = 1; i <= 10; ++i) {  // the shoulder meets body and neck without a kink
        const double t = i / 10.0;
        profile.emplace_back(neck + (body - neck) * 0.5 * (1.0 + std::cos(pi * t)), 0.15 + 0.05 * t);
    }
    profile.emplace_back(neck, 0.221);
    profile.emplace_back(0.0155, 0.221);  // the support ring under the cap
    profile.emplace_back(0.0155, 0.2235);
    profile.emplace_back(neck, 0.2235);
    profile.emplace_back(neck, 0.226);
    profile.emplace_back(0.015, 0.226);  // the cap
    profile.emplace_back(0.015, 0.2485);
    profile.emplace_back(0.0135, 0.25);
    profile.emplace_back(0.0, 0.25);
    return revolve(profile, 48);
}

// A 9.5 cm mug: a cylinder shell (outer radius 4 cm, inner 3.6 cm) with a rounded rim and a floor
// 8 mm thick, open on top, and a D-shaped handle on the +x side whose ends sink into the wall.
TriangleMesh make_mug()
{
    const double outer = 0.040;
    const double inner = 0.036;
    const double rim = 0.093;  // where the rounded rim starts; its top is one wall-half-thickness higher
    const double floor = 0.008;
    std::vector<Vec2> profile = {Vec2(0.0, 0.0), Vec2(outer - 0.003, 0.0)};
    add_arc(profile, Vec2(outer - 0.003, 0.003), 0.003, -90.0, 0.0, 3);
    profile.emplace_back(outer, rim);
    add_arc(profile, Vec2(0.5 * (outer + inner), rim), 0.5 * (outer - inner), 0.0, 180.0, 6);
    profile.emplace_back(inner, floor + 0.003);
    add_arc(profile, Vec2(inner - 0.003, floor + 0.003), 0.003, 0.0, -90.0, 3);
    profile.emplace_back(0.0, floor);
    TriangleMesh mug = revolve(profile, 48);

    // The handle's centre line is a half circle about a point on the outer wall, run a few degrees
    // past the vertical so that both end caps sit inside the wall, 2 mm under its outer surface.
    const double bend = 0.028;
    const double reach = std::acos(-0.002 / bend);
    append(mug, torus_segment(Vec(outer, 0.0, 0.05), Vec::UnitX(), Vec::UnitZ(), bend, 0.006, -reach, reach, 24, 12));
    return mug;
}

// A 20 x 5 x 26 cm cracker box with rounded vertical edges (6 mm radius) and 3 mm chamfers along
// the top and bottom edges, as a folded and glued carton has. Shallower than the milk carton is
// wide: a 7 cm deep box would hold a whole carton inside it, and no sensor can refute a carton
// hidden in a box whose front and back are the carton's.
TriangleMesh make_box()
{
    const double half_x = 0.10;
    const double half_y = 0.025;
    const double height = 0.26;
    const double radius = 0.006;
    const double chamfer = 0.003;
    const int steps = 4;
    const std::array<Ring, 4> rings = {
        rounded_rectangle(half_x - chamfer, half_y - chamfer, radius - chamfer, 0.0, steps),
        rounded_rectangle(half_x, half_y, radius, chamfer, steps),
        rounded_rectangle(half_x, half_y, radius, height - chamfer, steps),
        rounded_rectangle(half_x - chamfer, half_y - chamfer, radius - chamfer, height, steps)};
    return loft_capped(rings);
}

// A detergent jug: a 14 x 9 cm superellipse body with a bevelled foot, straight for 13 cm, then a
// shoulder tapering to a flat top at 17 cm; a screw cap towards the front (+x) and a handle loop
// at the back whose ends sink into the top and the back wall.
TriangleMesh make_jug()
{
    const double half_x = 0.07;
    const double half_y = 0.045;
    const int segments = 64;
    std::vector<Ring> rings = {superellipse(half_x, half_y, 0.93, 0.0, segments),
                               superellipse(half_x, half_y, 1.0, 0.005, segments),
                               superellipse(half_x, half_y, 1.0, 0.13, segments)};
    for (int i = 1; i <= 8; ++i) {  // the shoulder, leaving the side without a kink
        const double t = i / 8.0;
        rings.push_back(superellipse(half_x, half_y, 1.0 - 0.22 * 0.5 * (1.0 - std::cos(pi * t)), 0.13 + 0.04 * t,
                                     segments));
    }
    TriangleMesh jug = loft(rings, Vec::Zero(), Vec(0.0, 0.0, 0.17));

    const std::array<Vec2, 5> cap = {Vec2(0.0, 0.16), Vec2(0.019, 0.16), Vec2(0.019, 0.1935), Vec2(0.0175, 0.195),
                                     Vec2(0.0, 0.195)};
    append(jug, revolve(cap, 32, Vec(0.025, 0.0, 0.0)));
    // From inside the top (angle -30 degrees) over the top and down the back into the wall (260).
    append(jug, torus_segment(Vec(-0.052, 0.0, 0.165), Vec::UnitX(), Vec::UnitZ(), 0.032, 0.008, -pi / 6.0,
                              260.0 * pi / 180.0, 36, 16));
    return jug;
}

constexpr std::array<std::string_view, 5> object_names = {"carton", "bottle", "mug", "box", "jug"};

}  // namespace

std::span<const std::string_view> builtin_object_names()
{
    return object_names;
}

bool is_builtin_object(std::string_view name)
{
    for (std::string_view known : object_names) {
        if (name == known) return true;
    }
    return false;
}

int builtin_object_symmetry(std::string_view name)
{
    if (name == "carton" || name == "box") return 2;
    if (name == "bottle") return 0;
    if (name == "mug" || name == "jug") return 1;
    make_builtin_object(name);  // throws the unknown-name error
    return 1;
}

bool builtin_object_flips(std::string_view name)
{
    if (name == "box") return true;
    make_builtin_object(name);  // throws the unknown-name error
    return false;
}

TriangleMesh make_builtin_object(std::string_view name)
{
    if (name == "carton") return make_carton();
    if (name == "bottle") return make_bottle();
    if (name == "mug") return make_mug();
    if (name == "box") return make_box();
    if (name == "jug") return make_jug();
    std::string known;
    for (std::string_view each : object_names) known += (known.empty() ? "" : ", ") + std::string(each);
    throw Error("object", "unknown built-in object '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace mfpc
