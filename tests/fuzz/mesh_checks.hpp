#pragma once
// The checks of a mesh read_mesh accepted, shared by the PLY and OBJ mesh targets: what the reader
// documents (faces, finite vertices, indices in range), then sample_surface over it, as `synth`
// does with a mesh file: a deterministic cloud of finite points with unit normals near the mesh.
#include "fuzz_support.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace mfpc::fuzz {

inline void check_mesh(const TriangleMesh& mesh)
{
    check(!mesh.empty(), "read_mesh returned no faces");
    for (const Eigen::Vector3f& v : mesh.vertices) check(v.allFinite(), "read_mesh kept a non-finite vertex");
    for (const Eigen::Vector3i& t : mesh.triangles) {
        for (int corner = 0; corner < 3; ++corner) {
            check(t[corner] >= 0 && std::size_t(t[corner]) < mesh.vertices.size(), "a face names a missing vertex");
        }
    }
    // Sampling at a fiftieth of the mesh's size keeps each run short whatever the mesh's scale; a
    // big mesh is bounded by the reader's own input, so only its triangle count is capped here.
    if (mesh.triangles.size() > 4096) return;
    const Box bounds = mesh.bounds();
    const float extent = (bounds.max - bounds.min).maxCoeff();
    if (!(extent > 0) || !std::isfinite(extent)) return;
    run([&] {
        const PointCloud cloud = sample_surface(mesh, extent / 50, 1);
        check(cloud.normals.size() == cloud.size(), "sampled points without one normal each");
        const float slack = extent * 1e-4f;
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            check(finite(cloud.points[i]), "a sampled point is not finite");
            check((cloud.points[i].array() >= bounds.min.array() - slack).all() &&
                      (cloud.points[i].array() <= bounds.max.array() + slack).all(),
                  "a sampled point lies outside the mesh's bounds");
            check(std::abs(cloud.normals[i].norm() - 1) < 1e-3f, "a sampled normal is not unit length");
        }
    });
}

}  // namespace mfpc::fuzz
