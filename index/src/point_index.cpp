#include "mfpc/index/point_index.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include <openvdb/openvdb.h>
#include <openvdb/tools/PointIndexGrid.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// OpenVDB's point-array concept over our packed float xyz, without a copy.
struct PointArray {
    using PosType = openvdb::Vec3R;
    std::span<const Point> points;
    std::size_t size() const { return points.size(); }
    void getPos(std::size_t n, PosType& xyz) const
    {
        const Point& p = points[n];
        xyz = PosType(p.x(), p.y(), p.z());
    }
};

void initialize_openvdb()
{
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

}  // namespace

struct PointIndex::Grid {
    openvdb::math::Transform::Ptr transform;
    openvdb::tools::PointIndexGrid::Ptr grid;
};

PointIndex::PointIndex(std::span<const Point> points, const PointIndexParams& params)
    : points_(points), params_(params), grid_(std::make_unique<Grid>())
{
    if (!(params.voxel_size > 0.0f) || !std::isfinite(params.voxel_size)) {
        throw Error("index.voxel_size", "must be a positive number, got " + std::to_string(params.voxel_size));
    }
    if (points.size() >= std::numeric_limits<std::uint32_t>::max()) {
        throw Error("index", "clouds of 2^32 points or more are not supported");
    }
    initialize_openvdb();
    // Voxel (i, j, k) covers [i, i + 1) * voxel_size (OpenVDB's voxels are centred on the integer
    // coordinates, hence the half-voxel shift): the same lattice as downsampling voxels whose size
    // is a multiple of voxel_size, so a whole index voxel then falls in one downsampling voxel.
    grid_->transform = openvdb::math::Transform::createLinearTransform(params.voxel_size);
    grid_->transform->postTranslate(openvdb::Vec3d(0.5 * double(params.voxel_size)));
    grid_->grid = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(PointArray{points},
                                                                                      *grid_->transform);

    // Flatten the leaves into a table the kernels can walk in parallel without OpenVDB headers.
    std::vector<const openvdb::tools::PointIndexGrid::TreeType::LeafNodeType*> nodes;
    nodes.reserve(grid_->grid->tree().leafCount());
    for (auto leaf = grid_->grid->tree().cbeginLeaf(); leaf; ++leaf) {
        if (!leaf->indices().empty()) nodes.push_back(leaf.getLeaf());
    }
    // The tree's own iteration order is fixed for a given set of leaves; sorting by origin makes
    // the table independent of how the grid was built.
    std::sort(nodes.begin(), nodes.end(), [](const auto* a, const auto* b) { return a->origin() < b->origin(); });

    leaves_.resize(nodes.size());
    std::uint32_t offset = 0;
    std::uint32_t voxel_offset = 0;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        leaves_[i].begin = offset;
        leaves_[i].voxel_begin = voxel_offset;
        offset += static_cast<std::uint32_t>(nodes[i]->indices().size());
        voxel_offset += static_cast<std::uint32_t>(nodes[i]->onVoxelCount());
        leaves_[i].end = offset;
        leaves_[i].voxel_end = voxel_offset;
    }
    if (offset != points.size()) {
        throw Error("index", "bucketed " + std::to_string(offset) + " of " + std::to_string(points.size()) +
                                 " points (non-finite coordinates?)");
    }
    point_order_.resize(points.size());
    ordered_points_.resize(points.size());
    voxels_.resize(voxel_offset);
    tbb::parallel_for(std::size_t(0), nodes.size(), [&](std::size_t i) {
        PointIndexLeaf& leaf = leaves_[i];
        leaf.bounds = bounding_box(std::span<const Point>());
        std::uint32_t cursor = leaf.begin;
        std::uint32_t voxel = leaf.voxel_begin;
        for (auto value = nodes[i]->cbeginValueOn(); value; ++value, ++voxel) {
            const openvdb::tools::PointIndexGrid::TreeType::LeafNodeType::ValueType* begin = nullptr;
            const openvdb::tools::PointIndexGrid::TreeType::LeafNodeType::ValueType* end = nullptr;
            nodes[i]->getIndices(value.pos(), begin, end);
            PointIndexVoxel& v = voxels_[voxel];
            v.begin = cursor;
            std::uint32_t* out = point_order_.data() + cursor;
            std::copy(begin, end, out);
            cursor += static_cast<std::uint32_t>(end - begin);
            v.end = cursor;
            std::sort(out, point_order_.data() + cursor);
            v.bounds = bounding_box(std::span<const Point>());
            for (std::uint32_t k = v.begin; k < v.end; ++k) {
                const Point& p = points[point_order_[k]];
                ordered_points_[k] = p;
                v.sum += p.cast<double>();
                v.bounds.min = v.bounds.min.cwiseMin(p);
                v.bounds.max = v.bounds.max.cwiseMax(p);
            }
            leaf.bounds.min = leaf.bounds.min.cwiseMin(v.bounds.min);
            leaf.bounds.max = leaf.bounds.max.cwiseMax(v.bounds.max);
        }
    });
}

PointIndex::PointIndex(const PointCloud& cloud, const PointIndexParams& params) : PointIndex(cloud.points, params)
{
    if (!cloud.has_colors()) return;
    if (cloud.colors.size() != cloud.points.size()) {
        throw Error("index", "the cloud has " + std::to_string(cloud.colors.size()) + " colours for " +
                                 std::to_string(cloud.points.size()) + " points");
    }
    colors_ = cloud.colors;
    voxel_color_sums_.resize(voxels_.size());
    tbb::parallel_for(std::size_t(0), voxels_.size(), [&](std::size_t v) {
        std::array<std::uint64_t, 3>& sum = voxel_color_sums_[v];
        for (std::uint32_t k = voxels_[v].begin; k < voxels_[v].end; ++k) {
            const Rgb& c = colors_[point_order_[k]];
            sum[0] += c.r;
            sum[1] += c.g;
            sum[2] += c.b;
        }
    });
}

PointIndex::~PointIndex() = default;
PointIndex::PointIndex(PointIndex&&) noexcept = default;
PointIndex& PointIndex::operator=(PointIndex&&) noexcept = default;

namespace {

// Appends the points of the grid's voxels overlapping [lo, hi] (world) that pass `keep`, ascending.
// The voxel range is widened by one so that rounding in world-to-index never loses a point on a
// face; `keep` makes the exact decision.
template <typename Keep>
void collect(const openvdb::tools::PointIndexGrid& grid, const openvdb::math::Transform& xform,
             const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, Keep&& keep, std::vector<std::uint32_t>& out)
{
    const openvdb::Coord first =
        xform.worldToIndexCellCentered(openvdb::Vec3d(lo.x(), lo.y(), lo.z())) - openvdb::Coord(1);
    const openvdb::Coord last =
        xform.worldToIndexCellCentered(openvdb::Vec3d(hi.x(), hi.y(), hi.z())) + openvdb::Coord(1);
    openvdb::tools::PointIndexGrid::ConstAccessor accessor = grid.getConstAccessor();
    for (openvdb::tools::PointIndexIterator<> it(openvdb::CoordBBox(first, last), accessor); it; ++it) {
        if (keep(*it)) out.push_back(*it);
    }
    std::sort(out.begin(), out.end());
}

}  // namespace

void PointIndex::points_in_box(const Box& box, std::vector<std::uint32_t>& out) const
{
    out.clear();
    if (!box.valid() || points_.empty()) return;
    collect(*grid_->grid, *grid_->transform, box.min, box.max,
            [&](std::uint32_t i) { return box.contains(points_[i]); }, out);
}

void PointIndex::points_in_radius(const Point& center, float radius, std::vector<std::uint32_t>& out) const
{
    out.clear();
    if (!(radius >= 0.0f) || points_.empty()) return;
    const Eigen::Vector3f extent = Eigen::Vector3f::Constant(radius);
    const float radius_squared = radius * radius;
    collect(*grid_->grid, *grid_->transform, center - extent, center + extent,
            [&](std::uint32_t i) { return (points_[i] - center).squaredNorm() <= radius_squared; }, out);
}

std::size_t PointIndex::memory_bytes() const
{
    return static_cast<std::size_t>(grid_->grid->memUsage()) + leaves_.capacity() * sizeof(PointIndexLeaf) +
           voxels_.capacity() * sizeof(PointIndexVoxel) + point_order_.capacity() * sizeof(std::uint32_t) +
           ordered_points_.capacity() * sizeof(Point) +
           voxel_color_sums_.capacity() * sizeof(voxel_color_sums_[0]);
}

}  // namespace mfpc
