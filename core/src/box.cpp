#include "mfpc/core/box.hpp"

#include <limits>

namespace mfpc {

Box bounding_box(std::span<const Point> points)
{
    Box box;
    box.min.setConstant(std::numeric_limits<float>::infinity());
    box.max.setConstant(-std::numeric_limits<float>::infinity());
    for (const Point& p : points) box.extend(p);
    return box;
}

}  // namespace mfpc
