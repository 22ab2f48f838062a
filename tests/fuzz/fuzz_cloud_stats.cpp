// What `mfpc info` computes of a cloud: bounding_box and mean_spacing (index/, FLANN's kd-tree), on
// at most 512 fuzzed points, any finite float bits or on a grid (duplicates). Asserts the box holds
// every point and the spacing is a finite distance no larger than the box's diagonal.
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/core/box.hpp"
#include "mfpc/index/nearest_neighbors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    fuzz::Bytes bytes(data, size);
    const bool raw = bytes.byte() % 2;
    std::vector<Point> points;
    while (bytes.left() >= (raw ? 12u : 6u) && points.size() < 512) {
        Point p = raw ? Point(bytes.raw_float(), bytes.raw_float(), bytes.raw_float())
                      : Point(bytes.grid(-1, 1, 16), bytes.grid(-1, 1, 16), bytes.grid(-1, 1, 16));
        if (!fuzz::finite(p)) continue;  // readers keep only finite points
        points.push_back(p);
    }
    if (points.empty()) return 0;
    fuzz::run([&] {
        const Box box = bounding_box(points);
        for (const Point& p : points) fuzz::check(box.contains(p), "the bounding box misses a point");
        const double spacing = mean_spacing(points);
        fuzz::check(std::isfinite(spacing) && spacing >= 0, "mean spacing is not a finite distance");
        const double diagonal = (box.max.cast<double>() - box.min.cast<double>()).norm();
        // FLANN measures in float: allow its rounding, and the sqrt of a subnormal squared distance
        // (about 1e-19 at most, for points nearer than float can square).
        if (!(spacing <= diagonal * (1 + 1e-5) + 1e-18)) {
            fuzz::fail("mean spacing " + format_number(spacing) + " exceeds the cloud's diagonal " + format_number(diagonal) +
                       " (" + std::to_string(points.size()) + " points)");
        }
    });
    return 0;
}
