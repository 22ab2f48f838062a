// Builds a small cloud, indexes it and foveates it through the installed library; prints the
// number of points kept. Exits non-zero if the library misbehaves, so the packaging test catches it.
#include <cstdio>

#include <mfpc/core/foveation_config.hpp>
#include <mfpc/core/point_cloud.hpp>
#include <mfpc/index/point_index.hpp>
#include <mfpc/kernels/foveate.hpp>

int main()
{
    mfpc::PointCloud cloud;
    for (int i = 0; i < 20; ++i) {
        for (int j = 0; j < 20; ++j) cloud.points.emplace_back(0.01f * float(i), 0.01f * float(j), 1.0f);
    }
    cloud.width = static_cast<std::uint32_t>(cloud.size());

    mfpc::FoveationConfig config;
    config.levels = 2;
    mfpc::FoveatedStructure structure;
    structure.levels = 2;
    structure.outer_min = {-0.01f, -0.01f, 0.9f};
    structure.outer_size = {0.22f, 0.22f, 0.2f};
    structure.fovea_size = {0.05f, 0.05f, 0.05f};
    structure.density_outer = 0.04f;
    structure.density_fovea = 0.0f;
    config.structures.push_back(structure);

    const mfpc::PointIndex index(cloud.points);
    const mfpc::FoveatedCloud result = mfpc::foveate(cloud, index, config, mfpc::FoveationMode::mfpc);
    std::printf("consumer: %zu of %zu points kept\n", result.cloud.size(), cloud.size());
    return (result.cloud.size() > 0 && result.cloud.size() < cloud.size()) ? 0 : 1;
}
