// OrganizedNeighbors::nearest_batch, the depth image's nearest-point search that ICP and
// verification run on sensor scenes, against NeighborGrid::nearest on a small fuzzed depth image:
// up to 48 x 36 pixels seen by a pinhole of fuzzed focal length, each pixel without a return or at
// a depth on a grid (so that surfaces repeat and distances tie), and up to 256 fuzzed queries: near
// the points, along their rays (off the surface in depth), anywhere (past the image's edges, behind
// the sensor), or any float bits; any radius up to 0.3 m. The answers must be the grid's, bit for
// bit: the image's windows, tiles and bounds may only make the search faster.
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/core/camera.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    fuzz::Bytes bytes(data, size);
    PointCloud cloud;
    cloud.width = std::uint32_t(bytes.in(2, 48));
    cloud.height = std::uint32_t(bytes.in(2, 36));
    const float focal = bytes.grid(50.0f, 600.0f, 22);
    const float cell = bytes.grid(0.005f, 0.1f, 19);
    const float radius = bytes.grid(0.0f, 0.3f, 30);
    const float cx = 0.5f * float(cloud.width - 1), cy = 0.5f * float(cloud.height - 1);
    for (std::uint32_t v = 0; v < cloud.height; ++v)
        for (std::uint32_t u = 0; u < cloud.width; ++u) {
            const int depth = bytes.byte() % 65;  // 0: no return
            if (depth == 0) continue;
            const float z = 0.2f + 0.05f * float(depth);
            cloud.points.emplace_back((float(u) - cx) / focal * z, (float(v) - cy) / focal * z, z);
            cloud.source_index.push_back(v * cloud.width + u);
        }
    if (cloud.points.size() < 8) return 0;
    const std::optional<Camera> camera = fit_camera(cloud);
    if (!camera) return 0;

    std::vector<Point> queries;
    while (bytes.left() > 0 && queries.size() < 256) {
        const int kind = bytes.byte() % 4;
        const Point& near = cloud.points[std::size_t(bytes.u16()) % cloud.points.size()];
        if (kind == 0)
            queries.push_back(near + Point(bytes.grid(-0.03f, 0.03f, 12), bytes.grid(-0.03f, 0.03f, 12),
                                           bytes.grid(-0.03f, 0.03f, 12)));
        else if (kind == 1)
            queries.push_back(near * bytes.grid(0.5f, 1.5f, 40));
        else if (kind == 2)
            queries.emplace_back(bytes.grid(-3.0f, 3.0f), bytes.grid(-3.0f, 3.0f), bytes.grid(-0.5f, 4.0f));
        else
            queries.emplace_back(bytes.raw_float(), bytes.raw_float(), bytes.raw_float());
    }
    if (queries.empty()) return 0;

    fuzz::run([&] {
        const OrganizedNeighbors organized(cloud, *camera, 3, cell);
        const NeighborGrid grid(cloud.points, cell);
        std::vector<std::uint32_t> found(queries.size());
        std::vector<float> distances(queries.size(), -1.0f);
        organized.nearest_batch(queries, radius, found, distances);
        for (std::size_t q = 0; q < queries.size(); ++q) {
            std::uint32_t index = 0;
            float distance = -1.0f;
            const bool in_grid = grid.nearest(queries[q], radius, index, distance);
            const std::string where = "query " + std::to_string(q) + " (" + format_number(queries[q].x()) + ", " +
                                      format_number(queries[q].y()) + ", " + format_number(queries[q].z()) +
                                      "), radius " + format_number(radius);
            if (in_grid != (found[q] != OrganizedNeighbors::no_point))
                fuzz::fail(where + ": the grid " + (in_grid ? "found" : "did not find") + " a point, the image not");
            if (in_grid && (index != found[q] || distance != distances[q]))
                fuzz::fail(where + ": the image's nearest point is " + std::to_string(found[q]) + " at " +
                           format_number(distances[q]) + ", the grid's " + std::to_string(index) + " at " +
                           format_number(distance));
        }
    });
    return 0;
}
