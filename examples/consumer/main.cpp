// Uses MFPC as an installed package, the way another C++ pipeline would: builds a small cloud,
// writes and reads it back as PCD, indexes and foveates it. Exits non-zero if anything misbehaves,
// so the packaging test catches a broken install.
//   consumer OUT.pcd
#include <cstdint>
#include <cstdio>

#include <mfpc/core/cloud_io.hpp>
#include <mfpc/core/error.hpp>
#include <mfpc/core/foveation_config.hpp>
#include <mfpc/core/point_cloud.hpp>
#include <mfpc/index/point_index.hpp>
#include <mfpc/kernels/foveate.hpp>

int main(int argc, char** argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: consumer OUT.pcd\n");
        return 2;
    }
    try {
        mfpc::PointCloud written;
        for (int i = 0; i < 20; ++i) {
            for (int j = 0; j < 20; ++j) written.points.emplace_back(0.01f * float(i), 0.01f * float(j), 1.0f);
        }
        written.width = static_cast<std::uint32_t>(written.size());
        mfpc::write_cloud(argv[1], written, {mfpc::CloudEncoding::binary_compressed, false});
        const mfpc::PointCloud cloud = mfpc::read_cloud(argv[1]);
        if (cloud.points != written.points) {
            std::fprintf(stderr, "consumer: PCD round trip changed the points\n");
            return 1;
        }

        const mfpc::FoveationConfig config = mfpc::parse_foveation_config(R"({
            "levels": 2,
            "structures": [{"outer_min": [-0.01, -0.01, 0.9], "outer_size": [0.22, 0.22, 0.2],
                            "fovea_size": [0.05, 0.05, 0.05], "fovea_offset": [0, 0, 0],
                            "density": [0.04, 0], "keypoint_radius": [0.03, 0.01]}]})",
                                                                          "consumer config");
        const mfpc::PointIndex index(cloud.points);
        const mfpc::FoveatedCloud result = mfpc::foveate(cloud, index, config, mfpc::FoveationMode::mfpc);
        std::printf("consumer: %zu of %zu points kept\n", result.cloud.size(), cloud.size());
        return (result.cloud.size() > 0 && result.cloud.size() < cloud.size()) ? 0 : 1;
    } catch (const mfpc::Error& e) {
        std::fprintf(stderr, "consumer: %s\n", e.what());
        return 1;
    }
}
