#pragma once

/// @file
/// @brief Hypothesis refinement (ICP) and verification against the scene: fitness, coverage,
/// thickness, free space and continuation.

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "mfpc/recognition/grouping.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief What verification compares instances with: the scene's points, an index to search them
/// and, for organized scenes, its depth image and camera for the free-space test.
struct SceneEvidence {
    std::span<const Point> points;  ///< The scene's points.
    /// Where the scene points near a model point are found: the depth image of an organized scene,
    /// else a grid over points (cells of a few sensor spacings suit it best).
    const OrganizedNeighbors* organized = nullptr;
    /// The grid over points, when there is no depth image (see organized).
    const NeighborGrid* grid = nullptr;
    std::optional<Camera> camera;  ///< The scene's camera; nothing for an unorganized scene (no free-space test).
    std::vector<float> depth;  ///< camera->width * height, NaN where no return.
};
/// @brief The evidence of a scene searched through a grid.
/// @param scene The scene cloud.
/// @param grid A grid over the scene's points.
/// @param camera fit_camera(scene), or nothing for an unorganized scene (no free-space test then).
/// @return The evidence, with the scene's depth image when there is a camera.
SceneEvidence make_scene_evidence(const PointCloud& scene, const NeighborGrid& grid, std::optional<Camera> camera);
/// @brief The evidence of an organized scene searched through its depth image.
/// @param scene The organized scene cloud.
/// @param organized The search built over it, with its camera.
/// @return The evidence, with the scene's depth image and camera.
/// @throws mfpc::Error when `organized` is not over the scene's points.
SceneEvidence make_scene_evidence(const PointCloud& scene, const OrganizedNeighbors& organized);

/// @brief The model points that a sensor at the origin would see with the model placed at `pose`,
/// were nothing else in front of it.
///
/// A point is seen when its surface is turned to the sensor (less than acos(min_facing_cos) from
/// the ray) and the model does not hide it itself (a mug's inside behind its front wall): each
/// point stands for a disc of radius `spacing` in its tangent plane, and a point is hidden when the
/// ray to it crosses another's disc more than three spacings before reaching it (about the most by
/// which a disc at an edge of a convex model reaches over the face beside it).
/// @param points The model's points (model frame), sampled about `spacing` apart.
/// @param normals One per point; a point without a finite normal is not seen and hides nothing.
/// @param pose Where the model is (camera frame).
/// @param min_facing_cos The cosine of the most a seen surface may be turned from the ray.
/// @param spacing The points' sampling spacing (metres).
/// @return Per point, 1 where it is seen.
/// @throws mfpc::Error when the normals are not one per point.
std::vector<std::uint8_t> model_points_in_view(std::span<const Point> points, std::span<const Point> normals,
                                               const Pose& pose, float min_facing_cos, float spacing);

/// @brief What refine_and_verify needs of a model whatever the scene, for one set of refinement and
/// verification parameters: the thinned model, its point spacing, its confusable and quarter turns
/// and its rim probes. Made once per model (prepare_verification) rather than once per scene: about
/// 10 ms a scene and model at 2 threads, a third to a half of a real Kinect scene's verification.
struct ModelVerification;

/// @brief Prepares a model's verification for these parameters (see ModelVerification).
/// @param model_points The model cloud.
/// @param model_normals The model cloud's normals, one per point.
/// @param refine The refinement parameters it is for.
/// @param verify The verification parameters it is for.
/// @return The preparation, for refine_and_verify with this model and these parameters.
/// @throws mfpc::Error when the model's normals are not one per point.
std::shared_ptr<const ModelVerification> prepare_verification(std::span<const Point> model_points,
                                                              std::span<const Point> model_normals,
                                                              const RefineParams& refine, const VerifyParams& verify);
/// @brief Whether a preparation was made for these parameters (refine_and_verify refuses it
/// otherwise).
/// @param prepared The preparation.
/// @param refine The refinement parameters of the run.
/// @param verify The verification parameters of the run.
/// @return Whether both are those it was made for.
bool prepared_for(const ModelVerification& prepared, const RefineParams& refine, const VerifyParams& verify);

/// @brief Refines each instance by ICP, then keeps those the scene supports.
///
/// ICP (point to point, Umeyama per iteration) of each instance's model onto the scene, starting
/// from its pose, pairing only the model points the sensor would see (facing it, not hidden by the
/// model itself: paired, the hidden ones pull the pose toward the sensor); then fitness: the
/// fraction of the model points the sensor could have seen (normal
/// within acos(VerifyParams::min_facing_cos) of the ray to the origin, not hidden behind a nearer
/// observed surface, not hidden by the model itself) that have a scene point within
/// inlier_distance; the coverage: inliers over the model points facing the sensor that the model
/// does not hide itself (model_points_in_view), whether the scene hides them or not (how much of
/// the side of the model turned to the sensor the scene explains: for a model sampled all around an
/// object, its back can never be seen, so it does not count, nor can a side seen nearly edge on,
/// nor a mug's inside behind its front wall); the thickness ratio (the
/// fitting points' spread off their best plane over the facing side's: a model face flush on a
/// table is no evidence of the object); the free-space violation: the fraction of all model points
/// projecting onto an observed pixel whose surface, and that of every pixel around it, lies more
/// than free_space_margin behind them (a solid object there would have stopped the ray, so it
/// cannot be there); and the continuation: of the probes just past the edges of the fitting part of
/// the model, the fraction where the scene's surface goes on rather than the sensor seeing past
/// them (a pose slid along its object's face leaves the rest of the object there). Instances
/// failing the limits are dropped.
///
/// With VerifyParams::try_turns, an instance that passes, or that only its continuation or free
/// space refutes, is refined and tested again from its confusable turns: the turns about the axes
/// of the model's normals (through the point nearest their lines) under which at least
/// VerifyParams::turn_overlap of the model, but not 98%, lands within inlier_distance of itself,
/// in steps that move no point more than the ICP distance. Of the turns that pass (those that
/// start with at least as many facing points near the scene), it keeps the pose the scene supports
/// better where two poses differ: each model point counts +1 where it fits the scene, -1 where the
/// sensor would see it and saw past it, summed over the points of each pose with no point of the
/// other within the larger of inlier_distance and 1.5 point spacings (a mug's handle, not the body
/// both share). On a tie (the part that differs hidden at both), the pose whose seen points explain
/// the most depth pixels (a scene pixel is explained within 1.5 point spacings of a seen point and
/// inlier_distance of its tangent plane; without a depth image, the most model points fitting). One that passed but is not settled is also tried from quarter,
/// half and three-quarter turns about the model's principal axes, and keeps the pose with the most
/// model points fitting the scene.
///
/// Duplicates (placed models overlapping: merge_overlap of one's points within merge_distance of the
/// other's): instances are taken in the order given (grouping's: most votes first), and one that
/// starts on the place of a settled instance accepted before it (fitness at least
/// VerifyParams::settled_fitness) is dropped before its ICP; two accepted ones that overlap once
/// refined keep the one that explains more of the scene (more model points fitting it, then the
/// better coverage, then the better fitness). Instances keep their order otherwise.
/// @param instances The hypotheses, in grouping's order.
/// @param model_points The model cloud.
/// @param model_normals The model cloud's normals, one per point.
/// @param scene The scene's evidence.
/// @param refine The ICP parameters; refine.enabled says whether ICP runs.
/// @param verify The limits and the merging of duplicates; verify.enabled says whether they apply.
/// @param prepared The model's verification prepared for `refine` and `verify` (prepare_verification),
/// or null to make what is needed of it here. The result is the same.
/// @return The refined instances that pass the limits, with their scores; `instances` unchanged
/// when both refinement and verification are disabled.
/// @throws mfpc::Error when the model's normals are not one per point, the evidence has no scene
/// index, or `prepared` was made for other parameters or another number of model points.
std::vector<Instance> refine_and_verify(std::vector<Instance> instances, std::span<const Point> model_points,
                                        std::span<const Point> model_normals, const SceneEvidence& scene,
                                        const RefineParams& refine, const VerifyParams& verify,
                                        const ModelVerification* prepared = nullptr);

}  // namespace mfpc
