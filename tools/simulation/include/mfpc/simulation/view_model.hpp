#pragma once

#include <cstdint>
#include <vector>

#include "mfpc/recognition/model.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

// A recognition model of a whole object from views of it, as the virtual sensor would see it.
//
// Descriptors of a model sampled all around an object do not match a sensor's view of it: SHOT's
// support (4 cm) on a model carton also holds the faces a sensor cannot see from where a keypoint
// is seen, and the frames and histograms change with them (measured on a noise-free synthetic
// scene: the true model keypoint was never the nearest descriptor). So the object is scanned alone
// from `headings` directions at each elevation, each view is described as a scene would be (normals
// towards its sensor, uniform-sampling keypoints, BOARD, SHOT), and the keypoints and frames are
// moved into the object's frame. The model's points and normals, used by refinement and
// verification, are the object's full surface cloud.
struct ViewModelParams {
    int headings = 8;                              // views evenly around the object
    std::vector<float> elevations_deg = {30, 55};  // the composer's camera elevations
    float distance = 1.0f;                         // metres from the object's mid-height
    SensorParams sensor;                           // noise and quantization as in the scenes
    std::uint32_t seed = 1;                        // of the views' sensor noise
};

Model prepare_view_model(const SceneShape& shape, const PointCloud& surface, const FeatureParams& params,
                         const ViewModelParams& views = {}, FeatureTimings* timings = nullptr);

}  // namespace mfpc
