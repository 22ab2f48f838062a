#include "mfpc/core/camera.hpp"

#include <algorithm>
#include <cmath>

namespace mfpc {

std::optional<Camera> fit_camera(const PointCloud& organized)
{
    // No width: no pixel to fit against (and a division by zero below).
    if (!organized.organized() || organized.width == 0 || organized.size() < 100) return std::nullopt;
    // u = fx * x / z + cx, v = fy * y / z + cy: two straight-line fits.
    double sx = 0, su = 0, sxx = 0, sxu = 0, sy = 0, sv = 0, syy = 0, syv = 0;
    for (std::size_t i = 0; i < organized.size(); ++i) {
        const Point& p = organized.points[i];
        if (!(p.z() > 0.0f)) return std::nullopt;
        const std::uint32_t position = organized.source_position(i);
        const double u = position % organized.width, v = position / organized.width;
        const double x = double(p.x()) / p.z(), y = double(p.y()) / p.z();
        sx += x, su += u, sxx += x * x, sxu += x * u;
        sy += y, sv += v, syy += y * y, syv += y * v;
    }
    const double n = double(organized.size());
    const double fx = (n * sxu - sx * su) / (n * sxx - sx * sx);
    const double fy = (n * syv - sy * sv) / (n * syy - sy * sy);
    if (!std::isfinite(fx) || !std::isfinite(fy) || fx <= 0 || fy <= 0) return std::nullopt;
    Camera camera;
    camera.fx = float(fx);
    camera.fy = float(fy);
    camera.cx = float((su - fx * sx) / n);
    camera.cy = float((sv - fy * sy) / n);
    camera.width = organized.width;
    camera.height = organized.height;
    double squared = 0, largest = 0;
    for (std::size_t i = 0; i < organized.size(); ++i) {
        const Point& p = organized.points[i];
        const std::uint32_t position = organized.source_position(i);
        const double du = double(camera.fx) * p.x() / p.z() + camera.cx - double(position % organized.width);
        const double dv = double(camera.fy) * p.y() / p.z() + camera.cy - double(position / organized.width);
        squared += du * du + dv * dv;
        largest = std::max({largest, std::abs(du), std::abs(dv)});
    }
    if (std::sqrt(squared / n) > 1.0) return std::nullopt;
    camera.max_residual = float(largest);
    return camera;
}

}  // namespace mfpc
