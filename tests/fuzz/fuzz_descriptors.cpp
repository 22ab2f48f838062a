// Normals, uniform sampling, BOARD frames and SHOT descriptors on a small fuzzed cloud (at most
// 128 points on a 2.5 mm grid in a 10 cm cube, so neighbourhoods are full and degenerate ones
// common), with fuzzed k and radii. Asserts every output is defined or flagged undefined as the
// kernels document: a normal is a unit vector facing the viewpoint or all NaN; keypoints are
// distinct points of the cloud; a frame is a rotation or all NaN, and the counts of undefined ones
// are what the kernels return; a descriptor is all NaN or finite with unit length.
#include <vector>

#include <Eigen/LU>

#include "fuzz_support.hpp"
#include "mfpc/kernels/local_reference_frame.hpp"
#include "mfpc/kernels/normals.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"

namespace {

using namespace mfpc;

bool all_nan(const float* values, std::size_t count)
{
    for (std::size_t i = 0; i < count; ++i) {
        if (!std::isnan(values[i])) return false;
    }
    return true;
}

bool is_rotation(const LocalReferenceFrame& frame)
{
    return (frame * frame.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f &&
           std::abs(frame.determinant() - 1) < 1e-3f;
}

std::size_t check_frames(const std::vector<LocalReferenceFrame>& frames, const char* what)
{
    std::size_t undefined = 0;
    for (const LocalReferenceFrame& frame : frames) {
        if (is_valid(frame)) {
            fuzz::check(is_rotation(frame), what);
        } else {
            fuzz::check(all_nan(frame.data(), 9), "an undefined frame is not all NaN");
            ++undefined;
        }
    }
    return undefined;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    fuzz::Bytes bytes(data, size);
    NormalParams normal_params;
    normal_params.k = bytes.in(3, 16);
    normal_params.viewpoint = Point(bytes.grid(-1, 1, 8), bytes.grid(-1, 1, 8), bytes.grid(-1, 1, 8));
    const float cell = bytes.grid(0.0025f, 0.05f, 19);
    const float keypoint_radius = bytes.grid(0.005f, 0.05f, 9);
    BoardParams board;
    board.radius = bytes.grid(0.005f, 0.05f, 9);
    board.find_holes = bytes.byte() % 2;
    board.tangent_radius = bytes.byte() % 2 ? 0.0f : board.radius * bytes.grid(0.5f, 1, 4);
    ShotParams shot;
    shot.radius = bytes.grid(0.005f, 0.05f, 9);
    std::vector<Point> points;
    while (bytes.left() >= 6 && points.size() < 128) {
        points.emplace_back(bytes.grid(0, 0.1f, 40), bytes.grid(0, 0.1f, 40), bytes.grid(0, 0.1f, 40));
    }
    if (points.empty()) return 0;

    try {
        const NeighborGrid grid(points, cell);
        std::vector<Point> normals(points.size());
        estimate_normals(points, grid, normal_params, normals);
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (std::isnan(normals[i].x())) {
                fuzz::check(all_nan(normals[i].data(), 3), "an undefined normal is not all NaN");
                continue;
            }
            fuzz::check(fuzz::finite(normals[i]) && std::abs(normals[i].norm() - 1) < 1e-3f,
                        "a normal is neither NaN nor unit length");
            fuzz::check((normal_params.viewpoint - points[i]).dot(normals[i]) >= -1e-6f, "a normal faces away from the viewpoint");
        }

        const std::vector<std::uint32_t> sampled = uniform_sampling(points, keypoint_radius);
        std::vector<Point> keypoints;
        for (std::size_t i = 0; i < sampled.size(); ++i) {
            fuzz::check(sampled[i] < points.size(), "a keypoint index beyond the cloud");
            fuzz::check(i == 0 || sampled[i] > sampled[i - 1], "keypoint indices not ascending (a point twice)");
            keypoints.push_back(points[sampled[i]]);
        }
        fuzz::check(!keypoints.empty(), "uniform sampling kept no point of a cloud");

        std::vector<LocalReferenceFrame> frames(keypoints.size());
        const std::size_t undefined_frames = board_frames(keypoints, grid, normals, board, frames);
        fuzz::check(check_frames(frames, "a BOARD frame is not a rotation") == undefined_frames,
                    "board_frames miscounts its undefined frames");

        std::vector<LocalReferenceFrame> shot_frames(keypoints.size());
        std::vector<float> descriptors(keypoints.size() * shot_size);
        const std::size_t undefined = shot_descriptors(keypoints, grid, normals, shot, shot_frames, descriptors);
        check_frames(shot_frames, "a SHOT frame is not a rotation");
        std::size_t counted = 0;
        for (std::size_t i = 0; i < keypoints.size(); ++i) {
            const float* descriptor = descriptors.data() + i * shot_size;
            const bool frame_defined = is_valid(shot_frames[i]);
            if (all_nan(descriptor, shot_size)) {
                ++counted;
                continue;
            }
            fuzz::check(frame_defined, "a descriptor without a frame");
            double norm = 0;
            for (std::size_t j = 0; j < shot_size; ++j) {
                fuzz::check(std::isfinite(descriptor[j]), "a descriptor is partly NaN");
                norm += double(descriptor[j]) * descriptor[j];
            }
            fuzz::check(std::abs(std::sqrt(norm) - 1) < 1e-3, "a descriptor is not unit length");
        }
        fuzz::check(counted == undefined, "shot_descriptors miscounts its undefined descriptors");
    } catch (const Error& error) {
        // Every parameter above is one the kernels document as valid, and the points are finite.
        fuzz::fail(std::string("a descriptor kernel refused valid input: ") + error.what());
    }
    return 0;
}
