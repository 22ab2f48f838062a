#include "mfpc/index/point_index.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include <openvdb/openvdb.h>
#include <openvdb/tools/PointIndexGrid.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/detail/index_lattice.hpp"
#include "mfpc/index/detail/radix_sort.hpp"

namespace mfpc {

namespace {

constexpr std::uint64_t leaf_voxels = detail::index_leaf_voxels;

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
        throw Error("index.voxel_size", "must be a positive number, got " + format_number(params.voxel_size));
    }
    // OpenVDB refuses a transform whose scale cubed is within 1e-15 of zero (voxels of 1e-5 m).
    if (params.voxel_size < min_index_voxel_size) {
        throw Error("index.voxel_size", format_number(params.voxel_size) + " is below the smallest index voxel, " +
                                            format_number(min_index_voxel_size) + " m");
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
    grid_->grid = openvdb::tools::PointIndexGrid::create(openvdb::tools::PointIndexGrid::ValueType(0));
    grid_->grid->setTransform(grid_->transform);
    if (points.empty()) return;
    const std::size_t n = points.size();
    const tbb::blocked_range<std::size_t> all(0, n, 4096);

    // Each point's voxel as OpenVDB's cell-centred conversion gives it (Coord::round of the
    // world-to-index map, in double), so the tables and the grid are the ones
    // tools::createPointIndexGrid builds; one radix sort by (leaf, voxel, index) builds them in
    // less time and memory than its partitioner.
    const detail::IndexLattice lattice(params.voxel_size);
    const auto voxel_of = [&](const Point& p) { return lattice.voxel(p); };
    // The conversion is monotonic, so the extreme voxels are those of the bounding box, and
    // checking its corners checks every point. Far inside OpenVDB's 32-bit coordinates, so that
    // leaf origins and query boxes widened by a voxel cannot overflow.
    struct Extent {
        Box bounds = bounding_box(std::span<const Point>());
        bool finite = true;
    };
    const Extent extent = tbb::parallel_reduce(
        all, Extent{},
        [&](const auto& range, Extent e) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                e.finite &= points[i].allFinite();
                e.bounds.extend(points[i]);
            }
            return e;
        },
        [](Extent a, const Extent& b) {
            a.finite &= b.finite;
            a.bounds.extend(b.bounds);
            return a;
        });
    const Box& bounds = extent.bounds;
    const auto reachable = [&](const Point& p) { return lattice.reaches(p); };
    if (!extent.finite || !reachable(bounds.min) || !reachable(bounds.max)) {
        const auto bad = std::find_if(points.begin(), points.end(),
                                      [&](const Point& p) { return !p.allFinite() || !reachable(p); });
        throw Error("index", "point " + std::to_string(bad - points.begin()) +
                                 " is not finite or lies more than 2^30 voxels from the origin");
    }
    // Leaves numbered row-major over the occupied extent, x slowest: ascending numbers are
    // ascending origins (OpenVDB's Coord order). A voxel's key is its leaf number, then its offset
    // in the leaf (OpenVDB's voxel order).
    const Eigen::Vector3i lo = lattice.leaf(bounds.min);
    const Eigen::Vector3i hi = lattice.leaf(bounds.max);
    const Eigen::Vector3i span = hi - lo;  // each below 2^28 leaves
    const auto offset_in_leaf = detail::LeafNumbering::offset_in_leaf;
    std::vector<std::uint64_t> keys;
    if (const std::optional<detail::LeafNumbering> numbering = detail::LeafNumbering::over(lo, hi)) {
        const auto key_of = [&](std::size_t i) { return numbering->key(voxel_of(points[i])); };
        detail::sort_by_key(n, int(std::bit_width(numbering->key_count - 1)), key_of, point_order_, keys);
    } else {
        // Leaves too far apart to number (at the default 5 mm voxel, points some ten kilometres
        // apart on two or three axes: a stray point): the same order by four stable sorts,
        // offset, z, y, then x, and the occupied leaves numbered by rank instead, which is all the
        // tables below need of a key.
        struct Entry {
            std::uint32_t leaf[3];  // from lo
            std::uint32_t offset;
            std::uint32_t index;
        };
        std::vector<Entry> entries(n);
        tbb::parallel_for(all, [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                const Eigen::Vector3i v = voxel_of(points[i]);
                const Eigen::Vector3i leaf = v.unaryExpr([](int c) { return c >> 3; }) - lo;
                entries[i] = {{std::uint32_t(leaf.x()), std::uint32_t(leaf.y()), std::uint32_t(leaf.z())},
                              std::uint32_t(offset_in_leaf(v)), std::uint32_t(i)};
            }
        });
        detail::radix_sort(entries, 0, 9, [](const Entry& e) { return std::uint64_t(e.offset); });
        for (int axis = 2; axis >= 0; --axis)
            detail::radix_sort(entries, 0, int(std::bit_width(std::uint32_t(span[axis]))),
                               [axis](const Entry& e) { return std::uint64_t(e.leaf[axis]); });
        point_order_.resize(n);
        keys.resize(n);
        std::uint64_t rank = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const Entry& e = entries[k];
            if (k > 0 && !std::equal(e.leaf, e.leaf + 3, entries[k - 1].leaf)) ++rank;
            point_order_[k] = e.index;
            keys[k] = rank * leaf_voxels + e.offset;
        }
    }

    // Voxels start where the key changes, leaves where key / 512 does. The voxels are counted
    // first, so their table is allocated once (on a 10-million-point cloud, growing it cost page
    // faults).
    std::size_t voxel_count = 0;
    for (std::size_t k = 0; k < n; ++k) voxel_count += k == 0 || keys[k] != keys[k - 1];
    voxels_.resize(voxel_count);
    std::vector<std::uint32_t> leaf_first_voxel;
    std::size_t voxel_index = 0;
    for (std::size_t k = 0; k < n; ++k) {
        if (k > 0 && keys[k] == keys[k - 1]) continue;
        if (k == 0 || keys[k] / leaf_voxels != keys[k - 1] / leaf_voxels)
            leaf_first_voxel.push_back(std::uint32_t(voxel_index));
        voxels_[voxel_index].begin = std::uint32_t(k);
        if (voxel_index > 0) voxels_[voxel_index - 1].end = std::uint32_t(k);
        ++voxel_index;
    }
    voxels_.back().end = std::uint32_t(n);
    leaf_first_voxel.push_back(std::uint32_t(voxels_.size()));
    leaves_.resize(leaf_first_voxel.size() - 1);
    ordered_points_.resize(n);

    // Per leaf: the tables, and the OpenVDB leaf node, whose voxel values are the running end of
    // each voxel's indices within the leaf (what PointIndexLeafNode::getIndices reads).
    using LeafNode = openvdb::tools::PointIndexGrid::TreeType::LeafNodeType;
    std::vector<std::unique_ptr<LeafNode>> nodes(leaves_.size());
    tbb::parallel_for(std::size_t(0), leaves_.size(), [&](std::size_t l) {
        PointIndexLeaf& leaf = leaves_[l];
        leaf.voxel_begin = leaf_first_voxel[l];
        leaf.voxel_end = leaf_first_voxel[l + 1];
        leaf.begin = voxels_[leaf.voxel_begin].begin;
        leaf.end = voxels_[leaf.voxel_end - 1].end;
        leaf.bounds = bounding_box(std::span<const Point>());
        auto node = std::make_unique<LeafNode>();
        const Eigen::Vector3i first = voxel_of(points[point_order_[leaf.begin]]);
        node->setOrigin(openvdb::Coord(first.x() & ~7, first.y() & ~7, first.z() & ~7));
        node->indices().assign(point_order_.begin() + leaf.begin, point_order_.begin() + leaf.end);
        // Written through the raw buffer: setOffsetOn checks for delayed loading at every call.
        LeafNode::ValueType* ends = node->buffer().data();
        LeafNode::NodeMaskType& mask = node->getValueMask();
        openvdb::Index offset = 0;
        for (std::uint32_t index = leaf.voxel_begin; index < leaf.voxel_end; ++index) {
            PointIndexVoxel& v = voxels_[index];
            v.bounds = bounding_box(std::span<const Point>());
            for (std::uint32_t k = v.begin; k < v.end; ++k) {
                const Point& p = points[point_order_[k]];
                ordered_points_[k] = p;
                v.sum += p.cast<double>();
                v.bounds.extend(p);
            }
            leaf.bounds.extend(v.bounds);
            const openvdb::Index voxel_offset = openvdb::Index(keys[v.begin] % leaf_voxels);
            for (; offset < voxel_offset; ++offset) ends[offset] = v.begin - leaf.begin;
            mask.setOn(offset);
            ends[offset++] = v.end - leaf.begin;
        }
        for (; offset < LeafNode::SIZE; ++offset) ends[offset] = leaf.end - leaf.begin;
        nodes[l] = std::move(node);
    });
    openvdb::tree::ValueAccessor<openvdb::tools::PointIndexGrid::TreeType> accessor(grid_->grid->tree());
    for (std::unique_ptr<LeafNode>& node : nodes) accessor.addLeaf(node.release());
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
