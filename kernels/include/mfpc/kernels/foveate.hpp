#pragma once

/// @file
/// @brief Foveation (paper Algorithm 1): labelling an indexed cloud with the level regions of its
/// foveated structures, then downsampling each region at its density.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/point_index.hpp"

namespace mfpc {

/// @brief A stretch of the index's point order (positions begin..end of
/// PointIndex::point_order()) that lies in one region.
///
/// When the stretch is made of whole index voxels, they are voxel_begin .. voxel_end of
/// PointIndex::voxels(); otherwise its points were tested one by one, and they are some of the
/// points of one index voxel, voxel_begin == voxel_end.
struct RegionRun {
    std::uint32_t begin = 0;        ///< First position in PointIndex::point_order().
    std::uint32_t end = 0;          ///< One past the last.
    std::uint32_t voxel_begin = 0;  ///< First whole voxel in PointIndex::voxels().
    std::uint32_t voxel_end = 0;    ///< One past the last; voxel_begin when the points were tested.
    /// @brief Whether the run is made of whole index voxels.
    /// @return voxel_end > voxel_begin.
    bool whole_voxels() const { return voxel_end > voxel_begin; }
};

/// @brief The members of every level region (structure l, level k) of a foveation, before
/// downsampling.
///
/// Region r = l * (m + 1) + k. Members are point indices into the indexed cloud, in the index's
/// point order (voxel by voxel), which does not depend on the thread count. Regions made by
/// foveation_regions also keep their members as runs of the index's point order, so downsampling
/// can take whole index voxels at once; they refer to that index, which must outlive them.
struct FoveationRegions {
    int structures = 0;  ///< The number of structures.
    int levels = 0;      ///< m.
    std::vector<std::uint32_t> offsets;  ///< region_count() + 1 entries into members.
    std::vector<std::uint32_t> members;  ///< Point indices, region after region.
    std::vector<std::uint32_t> run_offsets;  ///< region_count() + 1 entries into runs, or empty.
    std::vector<RegionRun> runs;             ///< The members as runs of the index's point order, region after region.
    const PointIndex* index = nullptr;  ///< The index the runs refer to.
    /// Points covered by at least one structure. With coverage_pairs: their difference is what
    /// redundancy treatment removes, |raw| - |mfpc| before downsampling.
    std::size_t covered_points = 0;
    /// (point, structure) coverage pairs. With covered_points: their difference is what redundancy
    /// treatment removes, |raw| - |mfpc| before downsampling.
    std::size_t coverage_pairs = 0;

    /// @brief The number of regions.
    /// @return structures * (m + 1).
    int region_count() const { return structures * (levels + 1); }
    /// @brief The number of region (structure, level).
    /// @param structure The structure l.
    /// @param level The level k, 0 to m.
    /// @return l * (m + 1) + k.
    int region_id(int structure, int level) const { return structure * (levels + 1) + level; }
    /// @brief The members of region (structure, level).
    /// @param structure The structure l.
    /// @param level The level k, 0 to m.
    /// @return Its point indices, in the index's point order.
    std::span<const std::uint32_t> region(int structure, int level) const
    {
        const int r = region_id(structure, level);
        return std::span<const std::uint32_t>(members).subspan(offsets[std::size_t(r)],
                                                               offsets[std::size_t(r) + 1] - offsets[std::size_t(r)]);
    }
    /// @brief What redundancy treatment removes before downsampling.
    /// @return coverage_pairs - covered_points: |raw| - |mfpc|.
    std::size_t redundant_points() const { return coverage_pairs - covered_points; }
};

/// @brief Labels the indexed cloud with the level regions of `structures` (paper Algorithm 1,
/// Eq. 6).
///
///  - single: only structure `single_structure`; other structures' regions stay empty;
///  - raw:    every structure on its own: a point covered by several appears once per structure;
///  - mfpc:   redundancy treatment: each covered point once, in the densest region that covers it
///            (smallest d_k; then the higher level; then the earlier structure).
///
/// Points outside every outer box belong to no region. Walks the index's leaves: a leaf whose tight
/// bounds lie wholly inside one region (or outside) of every structure is labelled without testing
/// its points; only leaves straddling a box face test points. All structures must have the same
/// number of levels. mode none is not a labelling (see foveate()) and throws.
/// @param index The indexed cloud; the regions' runs refer to it, so it must outlive them.
/// @param structures The foveated structures.
/// @param mode single, raw or mfpc.
/// @param single_structure The structure labelled in mode single.
/// @return The members of every region, as indices and as runs of the index's point order.
/// @throws mfpc::Error for mode none, no structures, levels below 1 or above max_levels, structures
/// with different numbers of levels, more regions than region ids can number, or (mode single) a
/// `single_structure` that does not exist.
FoveationRegions foveation_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                                   FoveationMode mode, int single_structure = 0);

/// @brief What downsampling did to one region.
struct RegionSummary {
    int structure = -1;    ///< The structure l.
    int level = -1;        ///< The level k.
    float density = 0.0f;  ///< d_k, voxel size (0: no downsampling).
    std::size_t points_before = 0;  ///< Members before downsampling.
    std::size_t points_after = 0;   ///< Points kept.
};

/// @brief A foveated cloud: the kept points (with normals, colours and source positions carried
/// over), the region label of each, and one summary per region.
struct FoveatedCloud {
    PointCloud cloud;                    ///< The kept points.
    std::vector<RegionLabel> labels;     ///< The region of each kept point.
    std::vector<RegionSummary> regions;  ///< One summary per region.
    std::size_t points_before_downsampling = 0;  ///< Members of all regions together.
    std::size_t redundant_points = 0;  ///< |raw| - |mfpc| before downsampling (see FoveationRegions).
    /// Wall-clock milliseconds of labelling in the foveate() call that made it (the one-shot
    /// foveate: its pass over the whole cloud, keys included; without its fallback's selection and
    /// indexing; 0 from downsample_regions and for mode none).
    double label_ms = 0.0;
    /// Wall-clock milliseconds of downsampling in the foveate() call that made it (0 from
    /// downsample_regions and for mode none).
    double downsample_ms = 0.0;
};

/// @brief Downsamples each region on its own with its structure's d_k; regions never mix.
///
/// A voxel grid anchored at the world origin, voxel (i, j, k) = floor(p * (1 / d_k)) per axis in
/// double (a multiplication by the inverse, as PCL's VoxelGrid):
///  - voxel:   the centroid of the voxel's points, summed in double in member order (normals
///             averaged and renormalised, colours averaged; the source position is the voxel's
///             lowest-index point's); a whole index voxel inside one downsampling voxel is added
///             without computing its points' voxels;
///  - uniform: the voxel's original point nearest the voxel centre (ties: the lowest index).
///
/// Output: regions in order; within a region, voxels in the order of their first member;
/// d_k = 0 keeps every member.
/// @param cloud The cloud the regions were labelled on.
/// @param regions The regions, from foveation_regions or made by hand.
/// @param structures The structures, which give each region's d_k.
/// @param downsample voxel or uniform.
/// @return The foveated cloud (label_ms and downsample_ms 0).
/// @throws mfpc::Error for regions that do not fit the structures, the cloud or their index
/// (another count of structures or levels, offsets that do not partition the members or runs, a
/// member beyond the cloud, regions labelled on another cloud, a run beyond the index), for
/// structures foveation_regions would refuse, and for a region whose coordinates are too large for
/// its voxels or that spans more than 2^21 of them on one axis.
FoveatedCloud downsample_regions(const PointCloud& cloud, const FoveationRegions& regions,
                                 std::span<const FoveatedStructure> structures, Downsample downsample);

/// @brief Labelling then downsampling; mode none returns the cloud unchanged with no labels
/// (-1, -1).
///
/// The same result as downsample_regions over foveation_regions, without listing the members:
/// downsampling reads them through the runs.
/// @param cloud The cloud.
/// @param index The index, which must have been built over cloud.points.
/// @param config The structures and the downsampling.
/// @param mode none, single, raw or mfpc.
/// @param single_structure The structure foveated in mode single.
/// @return The foveated cloud, with the time of each step.
/// @throws mfpc::Error when the index was not built over cloud.points, or as foveation_regions and
/// downsample_regions.
FoveatedCloud foveate(const PointCloud& cloud, const PointIndex& index, const FoveationConfig& config,
                      FoveationMode mode, int single_structure = 0);

/// @brief The same for one foveation of a cloud with no index at hand, without building one: each
/// point is tested against the level boxes in parallel blocks of the cloud, and downsampling is told
/// where an index would list each covered point (its leaf and voxel, then its number), so that it
/// emits the same points in the same order as foveate() over a default PointIndex of the whole
/// cloud. How the centroid sums are grouped does not matter (float coordinates sum exactly in
/// double, but for ones within about 1e-9 of zero beside larger ones). Structures reaching too far
/// to number the index's leaves in 64 bits (thousands of kilometres) fall back to indexing the
/// points inside some outer box. Reuse an index instead when foveating one cloud several times.
/// @param cloud The cloud.
/// @param config The structures and the downsampling.
/// @param mode none, single, raw or mfpc.
/// @param single_structure The structure foveated in mode single.
/// @return The foveated cloud, with the time of each step (label_ms: the labelling pass).
/// @throws mfpc::Error for a cloud check_cloud rejects, for covered points PointIndex refuses (the
/// fallback), or as foveation_regions and downsample_regions.
FoveatedCloud foveate(const PointCloud& cloud, const FoveationConfig& config, FoveationMode mode,
                      int single_structure = 0);

}  // namespace mfpc
