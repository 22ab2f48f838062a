#pragma once

/// @file
/// @brief Recognition models of whole objects described from virtual views of them.

#include <cstdint>
#include <vector>

#include "mfpc/recognition/model.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

/// @brief The views of prepare_view_model: a recognition model of a whole object from views of it,
/// as the virtual sensor would see it.
///
/// Descriptors of a model sampled all around an object do not match a sensor's view of it: SHOT's
/// support (4 cm) on a model carton also holds the faces a sensor cannot see from where a keypoint
/// is seen, and the frames and histograms change with them (measured on a noise-free synthetic
/// scene: the true model keypoint was never the nearest descriptor). So the object is scanned alone
/// from `headings` directions at each elevation, each view is described as a scene would be (normals
/// towards its sensor, uniform-sampling keypoints, BOARD, SHOT), and the keypoints and frames are
/// moved into the object's frame. The model's points and normals, used by refinement and
/// verification, are the object's full surface cloud.
struct ViewModelParams {
    int headings = 8;                              ///< Views evenly around the object.
    std::vector<float> elevations_deg = {30, 55};  ///< The composer's camera elevations.
    float distance = 1.0f;                         ///< Metres from the object's mid-height.
    SensorParams sensor;                           ///< Noise and quantization as in the scenes.
    std::uint32_t seed = 1;                        ///< Of the views' sensor noise.
};

/// @brief Prepares a model of a whole object from views of it (see ViewModelParams).
///
/// Each view is described at params.resolution when that is positive (describe_at_resolution),
/// else as sampled; a view with fewer than 3 points is skipped.
/// @param shape The object.
/// @param surface Its full surface cloud with normals (e.g. sample_surface of its mesh): the
/// model's points and normals.
/// @param params How the views are described.
/// @param views The views.
/// @param timings When given, the time of each description step is added to it.
/// @return The model: the surface cloud, and the views' keypoints, frames and descriptors in the
/// object's frame.
/// @throws mfpc::Error naming the shape for no headings or no elevations, a surface cloud without
/// points or normals, or a model with fewer than 3 usable keypoints (require_model_keypoints), or
/// as the scanner and the description.
Model prepare_view_model(const SceneShape& shape, const PointCloud& surface, const FeatureParams& params,
                         const ViewModelParams& views = {}, FeatureTimings* timings = nullptr);

}  // namespace mfpc
