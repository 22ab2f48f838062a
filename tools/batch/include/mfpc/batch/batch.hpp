#pragma once

/// @file
/// The batch driver: many scenes, several models, one JSON line per scene.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

/// The scenes of a batch from what the user named, in a stable order: a folder gives its .pcd and
/// .ply files in name order; a .pcd or .ply file is itself; any other file is a list, one scene
/// per line (blank lines and lines starting with '#' skipped; relative paths from the list's
/// folder); a name with * ? or [ is a glob, matched in name order. The same scene named twice
/// is kept once, where it first appears.
/// @param specs what --scenes was given, in order
/// @return the scene files
/// @throws mfpc::Error naming the spec for a folder, list or file that cannot be read, a glob that
///         matches nothing, or no scene at all
std::vector<std::filesystem::path> list_scenes(const std::vector<std::string>& specs);

/// A model of a batch: its name in the records (the file's stem) and the model itself.
struct BatchModel {
    std::string name;  ///< the model's file stem, as records name it
    Model model;       ///< described, or read from its cache
};

/// What one batch runs.
struct BatchJob {
    std::vector<std::filesystem::path> scenes;  ///< in the order their records are written
    std::vector<BatchModel> models;             ///< each scene is described once and matched against each
    RecognitionParams params;                   ///< the scene side and what every model's run uses
    const FoveationConfig* fovea = nullptr;     ///< foveate every scene with this config (mfpc mode); none: plain
    /// Place each scene's foveae itself (place_foveae with every model of the batch) and foveate it
    /// with them (mfpc mode); a scene where nothing is placed runs plain. Not with `fovea`.
    /// Strategy track makes the scenes the frames of one sequence, in the order of `scenes`: one
    /// PlacementTrack is carried from frame to frame and told each frame's instances, so the frames
    /// run one after another (see is_sequence). Oracle needs a ground truth, which a batch has not.
    std::optional<PlacementParams> placement;
};

/// Whether a job's scenes are the frames of one sequence: its placement is track.
/// @param job the batch
/// @return true for placement track
bool is_sequence(const BatchJob& job);

/// Checks what a job asks for before any scene runs.
/// @param job the batch
/// @throws mfpc::Error for no model, both `fovea` and `placement`, placement oracle, or placement
///         parameters check_placement_params refuses
void check_batch_job(const BatchJob& job);

/// Milliseconds of a batch's stages, summed over scenes: reading, the placement of the foveae, the
/// scene's description (foveation, normals, keypoints, frames, descriptors, evidence), and the
/// models' matching, grouping and verification.
struct StageTimes {
    double read = 0;      ///< reading the scene files
    double place = 0;     ///< placing the foveae (BatchJob::placement; 0 without)
    double describe = 0;  ///< describing each scene once
    double models = 0;    ///< every model's matching, grouping, refinement and verification
    double total = 0;     ///< each scene from its read to its record
};

/// One scene's outcome: its record line, and what the summary counts.
struct SceneRecord {
    std::size_t index = 0;                   ///< into BatchJob::scenes
    bool ok = false;                         ///< false: the scene could not be read or recognised
    std::string line;                        ///< the JSON record with its line break
    std::vector<std::size_t> instances;      ///< per model (empty on error)
    StageTimes stages;                       ///< where the scene's time went (what was reached on error)
};

/// Reads and recognises scene `index` of the job: the record's JSON line (see the README,
/// `mfpc batch`) with per model its instances and counts, the placement when the job places, the
/// timings, or the error that stopped the scene. Never throws for a bad scene: that is an error
/// record.
/// @param job the batch
/// @param index the scene, into job.scenes
/// @param track a sequence's state (is_sequence): placed from, then told the instances of every
///        model found in this frame (track_update); a frame that fails leaves it as it was. Only
///        for a sequence, and required there.
/// @return the record
/// @throws mfpc::Error for a job check_batch_job refuses, or a track missing or given where it is
///         not one's
SceneRecord recognize_scene(const BatchJob& job, std::size_t index, PlacementTrack* track = nullptr);

/// Brings a sequence's track to where it stood after a frame whose record an earlier run wrote:
/// the frame counted as placed and its instances followed, as recognize_scene left it (an error
/// record leaves it as it was). Replaying the records of the frames before gives the track an
/// uninterrupted run has, so a resumed sequence writes the records that run writes.
/// @param job the batch (its models name the record's)
/// @param record the frame's record line
/// @param track the sequence's state
/// @throws mfpc::Error for a record that is not a batch record or names a model the job lacks
void replay_record(const BatchJob& job, const std::string& record, PlacementTrack& track);

/// The JSONL file a batch appends to. Every record is one line, written by one write() of the
/// whole line and flushed, so a batch killed at any moment leaves whole lines and at most the
/// scenes in flight missing; a torn last line (a kill inside the write, a full disk) is cut off
/// when the file is opened again with resume.
class BatchOutput {
public:
    /// Opens `path` for appending.
    /// @param path the output file
    /// @param resume keep the records there (cutting a torn last line) and report their scenes
    ///        through done(); without it an existing file is an error, so that no run is lost
    /// @throws mfpc::Error when the file exists without resume, cannot be opened, or holds a line
    ///         that is not a batch record
    BatchOutput(const std::filesystem::path& path, bool resume);
    /// Flushes the records to the disk and closes the file.
    ~BatchOutput();
    BatchOutput(const BatchOutput&) = delete;
    BatchOutput& operator=(const BatchOutput&) = delete;

    /// @return the scenes (as their records name them) already in the file when it was opened
    const std::set<std::string>& done() const { return done_; }
    /// @return how many records the file held when it was opened (a resumed batch's earlier part)
    std::size_t kept() const { return kept_; }

    /// @return the file's path
    const std::filesystem::path& path() const { return path_; }

    /// Counts `scenes` as done as well (those another file already holds).
    /// @param scenes scene names as records give them
    void mark_done(const std::set<std::string>& scenes) { done_.insert(scenes.begin(), scenes.end()); }

    /// The scenes a batch output holds, read without changing it; a torn last line is not counted.
    /// @param path the output (nothing when it does not exist)
    /// @return the scenes of its whole records
    /// @throws mfpc::Error for a line that is not a batch record
    static std::set<std::string> scenes_in(const std::filesystem::path& path);

    /// Appends one record line.
    /// @param line the record, ending in a line break
    /// @throws mfpc::Error when the write fails (the disk is full, ...)
    void append(const std::string& line);

private:
    std::filesystem::path path_;
    int fd_ = -1;
    std::set<std::string> done_;
    std::size_t kept_ = 0;
};

/// What a batch did.
struct BatchSummary {
    std::size_t scenes = 0;                   ///< in the job
    std::size_t skipped = 0;                  ///< already in the output (resume)
    std::size_t recognised = 0;               ///< run now and succeeded
    std::size_t failed = 0;                   ///< run now and failed (error records)
    std::vector<std::string> model_names;     ///< the models, in the job's order
    std::vector<std::size_t> instances;       ///< per model, over the scenes run now
    StageTimes stages;                        ///< summed over the scenes run now (worker time, not wall time)
    double seconds = 0;                       ///< wall time of the scenes run now
    std::size_t peak_memory_bytes = 0;        ///< the process's peak resident memory at the end (0: unknown)
};

/// Called after each scene's record is written: scenes done (skipped ones included), all scenes,
/// and the scene just written.
using BatchProgress = std::function<void(std::size_t done, std::size_t total, const std::string& scene)>;

/// Which scenes of a job this process runs: those whose index modulo `count` is `rank` (every
/// scene for one process). Interleaving spreads scenes of unequal cost evenly when neighbours in
/// the list are alike, as frames of a sequence are.
struct BatchShare {
    int rank = 0;   ///< this process, 0..count-1
    int count = 1;  ///< processes sharing the job
};

/// Runs the job's scenes not in output.done(): read, described once, matched against every model,
/// verified, written, through a bounded TBB pipeline (at most `in_flight` scenes at once, so memory
/// stays flat whatever the number of scenes; 0: the threads available) that writes the records in
/// the job's order.
///
/// A sequence (is_sequence) runs its frames one after another, in the job's order (each frame's
/// placement follows the instances of the frames before; the work within a frame is still
/// parallel), and cannot be shared between processes. Frames the output already holds are not run
/// again: their records are replayed into the track (replay_record), so a resumed sequence
/// writes what an uninterrupted one writes (timings aside).
/// @param job the batch
/// @param output where the records go
/// @param share which scenes this process runs
/// @param progress told after each record
/// @param in_flight scenes in the pipeline at once (0: the worker threads)
/// @return the summary of the scenes run now
/// @throws mfpc::Error for a job check_batch_job refuses, a sequence shared between processes or
///         whose done frames' records are not in the output, or when a record cannot be written
///         (a bad scene is a record, not an error)
BatchSummary run_batch(const BatchJob& job, BatchOutput& output, const BatchShare& share = {},
                       const BatchProgress& progress = {}, std::size_t in_flight = 0);

/// Where process `rank` of a shared batch writes its records before they are merged: OUT.part-RANK.
/// @param output the batch's output
/// @param rank the process
/// @return the part's path
std::filesystem::path part_path(const std::filesystem::path& output, int rank);

/// Merges the parts of a shared batch into its output: the records already there first, then every
/// part's in the job's order, so that the output is the one a single process writes (timings
/// aside); written to a temporary file and renamed, then the parts are removed.
/// @param job the batch
/// @param output the batch's output (may not exist yet)
/// @param parts the processes' parts
/// @throws mfpc::Error when a file cannot be read or written, or holds a line that is not a record
void merge_parts(const BatchJob& job, const std::filesystem::path& output,
                 const std::vector<std::filesystem::path>& parts);

/// The summary as a text table: scenes, skipped, recognised, failed, instances per model, throughput.
/// @param summary what a batch did
/// @return text with a final newline
std::string to_table(const BatchSummary& summary);

/// The summary as JSON text.
/// @param summary what a batch did
/// @return indented JSON text with a final newline
std::string to_json(const BatchSummary& summary);

}  // namespace mfpc
