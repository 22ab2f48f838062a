#include "mfpc/batch/batch.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <map>
#include <new>
#include <optional>

#include <nlohmann/json.hpp>
#include <tbb/info.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/peak_memory.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/placement.hpp"

namespace mfpc {
namespace {

using nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

// One line: no indentation, and a file name that is not UTF-8 gets U+FFFD rather than failing
// the record after the work is done.
std::string record_line(const ordered_json& record)
{
    return record.dump(-1, ' ', false, ordered_json::error_handler_t::replace) + '\n';
}

ordered_json instance_json(const Instance& instance, const Point& centroid)
{
    ordered_json transform = ordered_json::array();
    for (double v : pose_to_row_major(instance.transform)) transform.push_back(v);
    const Point position = instance.transform * centroid;
    return {{"transform", transform},
            {"position", {position.x(), position.y(), position.z()}},
            {"votes", instance.votes},
            {"fitness", instance.fitness},
            {"coverage", instance.coverage}};
}

// The whole lines of a batch output (a torn last line left out), each checked to be a record.
std::vector<std::pair<std::string, std::string>> record_lines(const std::string& text, const std::filesystem::path& path)
{
    std::vector<std::pair<std::string, std::string>> records;  // scene, line with its break
    std::size_t line_number = 0;
    for (std::size_t begin = 0; begin < text.size();) {
        const std::size_t end = text.find('\n', begin);
        if (end == std::string::npos) break;
        ++line_number;
        const std::string_view line(text.data() + begin, end - begin);
        const nlohmann::json record = nlohmann::json::parse(line, nullptr, false);
        if (!record.is_object() || !record.contains("scene") || !record["scene"].is_string())
            throw Error(path.string(), "line " + std::to_string(line_number) +
                                           " is not a batch record: is this the output of `mfpc batch`?");
        records.emplace_back(record["scene"].get<std::string>(), std::string(text, begin, end + 1 - begin));
        begin = end + 1;
    }
    return records;
}

// The job's models as place_foveae and track_update take them.
std::vector<const Model*> model_pointers(const BatchJob& job)
{
    std::vector<const Model*> models;
    for (const BatchModel& model : job.models) models.push_back(&model.model);
    return models;
}

}  // namespace

bool is_sequence(const BatchJob& job)
{
    return job.placement && job.placement->strategy == PlacementStrategy::track;
}

void check_batch_job(const BatchJob& job)
{
    if (job.models.empty()) throw Error("batch", "no model to recognise");
    if (!job.placement) return;
    if (job.fovea) throw Error("batch", "a foveation config and automatic placement exclude each other");
    if (job.placement->strategy == PlacementStrategy::oracle)
        throw Error("batch", "placement oracle needs each scene's ground truth, which a batch does not have");
    check_placement_params(*job.placement);
}

void replay_record(const BatchJob& job, const std::string& record, PlacementTrack& track)
{
    const nlohmann::json json = nlohmann::json::parse(record, nullptr, false);
    if (!json.is_object() || !json.contains("scene") || !json["scene"].is_string())
        throw Error("batch", "not a batch record: " + record.substr(0, 80));
    const std::string scene = json["scene"].get<std::string>();
    if (json.value("status", "") != "ok") return;  // a failed frame left the track as it was
    // Only a sequence's own records rebuild its track: another batch's instances are not what
    // this one would have followed.
    const nlohmann::json* placement = json.contains("placement") ? &json["placement"] : nullptr;
    if (!placement || !placement->is_object() || placement->value("strategy", "") != "track")
        throw Error(scene, "the record was not written by a --sequence batch: its track cannot be rebuilt");
    const std::vector<const Model*> models = model_pointers(job);
    std::vector<PlacedInstance> found;
    try {
        for (const nlohmann::json& model : json.at("models")) {
            const std::string name = model.at("model").get<std::string>();
            const auto it = std::find_if(job.models.begin(), job.models.end(),
                                         [&](const BatchModel& m) { return m.name == name; });
            if (it == job.models.end())
                throw Error(scene, "the record names model '" + name + "', which this batch does not have");
            for (const nlohmann::json& instance : model.at("instances"))
                found.push_back({std::size_t(it - job.models.begin()),
                                 pose_from_row_major(instance.at("transform").get<std::vector<double>>(), scene)});
        }
    } catch (const nlohmann::json::exception& e) {
        throw Error(scene, std::string("the record's instances cannot be read: ") + e.what());
    }
    ++track.frame;  // as place_foveae counts the frame
    track_update(track, models, found, job.placement ? job.placement->track_refresh : PlacementParams{}.track_refresh);
}

std::set<std::string> BatchOutput::scenes_in(const std::filesystem::path& path)
{
    std::set<std::string> scenes;
    std::error_code error;
    if (!std::filesystem::exists(path, error)) return scenes;
    for (const auto& [scene, line] : record_lines(read_text_file(path), path)) scenes.insert(scene);
    return scenes;
}

std::filesystem::path part_path(const std::filesystem::path& output, int rank)
{
    return output.string() + ".part-" + std::to_string(rank);
}

void merge_parts(const BatchJob& job, const std::filesystem::path& output,
                 const std::vector<std::filesystem::path>& parts)
{
    std::error_code error;
    std::string merged;
    if (std::filesystem::exists(output, error))
        for (const auto& [scene, line] : record_lines(read_text_file(output), output)) merged += line;
    std::map<std::string, std::string> lines;
    for (const std::filesystem::path& part : parts)
        if (std::filesystem::exists(part, error))
            for (auto& [scene, line] : record_lines(read_text_file(part), part)) lines[scene] = std::move(line);
    for (const std::filesystem::path& scene : job.scenes) {
        const auto line = lines.find(scene.string());
        if (line != lines.end()) merged += line->second;
    }
    write_file_atomically(output, [&](std::ofstream& out) { out << merged; });
    for (const std::filesystem::path& part : parts) std::filesystem::remove(part, error);
}

SceneRecord recognize_scene(const BatchJob& job, std::size_t index, PlacementTrack* track)
{
    check_batch_job(job);
    if (is_sequence(job) && !track) throw Error("batch", "a sequence's frame needs the track of the frames before");
    if (!is_sequence(job) && track) throw Error("batch", "a track is only for a sequence (placement track)");
    SceneRecord record;
    record.index = index;
    const std::string scene_name = job.scenes.at(index).string();
    const auto start = Clock::now();
    // A frame that fails is not one the sequence has seen.
    const PlacementTrack before = track ? *track : PlacementTrack{};
    std::string error;
    try {
        const PointCloud scene = read_cloud(job.scenes[index]);
        const double read_ms = elapsed_ms(start);
        record.stages.read = read_ms;
        const std::vector<const Model*> pointers = model_pointers(job);
        std::optional<PlacementResult> placement;
        const FoveationConfig* config = job.fovea;
        if (job.placement) {
            // A placement that places nothing leaves the scene to the plain pipeline.
            placement = place_foveae(scene, pointers, job.params, *job.placement, {}, track);
            record.stages.place = placement->ms;
            if (!placement->config.structures.empty()) config = &placement->config;
        }
        const SceneFoveation foveation{config, config ? FoveationMode::mfpc : FoveationMode::none, 0};
        const std::unique_ptr<DescribedScene> described = describe_scene(scene, job.params, foveation);
        ordered_json models = ordered_json::array();
        ordered_json model_ms = ordered_json::array();
        std::vector<PlacedInstance> found;
        for (std::size_t m = 0; m < job.models.size(); ++m) {
            const BatchModel& model = job.models[m];
            const RecognitionResult result =
                recognize_described(*described, model.model, nullptr, SceneFeatures::left_out);
            const Point centroid = model_centroid(model.model);
            ordered_json instances = ordered_json::array();
            for (const Instance& instance : result.instances) {
                instances.push_back(instance_json(instance, centroid));
                found.push_back({m, instance.transform});
            }
            models.push_back({{"model", model.name},
                              {"instances", instances},
                              {"correspondences", result.counts.correspondences},
                              {"instances_before_verification", result.counts.instances_before_verification}});
            model_ms.push_back(result.timings.total);
            record.stages.models += result.timings.total;
            record.instances.push_back(result.instances.size());
        }
        if (track) track_update(*track, pointers, found, job.placement->track_refresh);
        record.stages.describe = described->timings.total;
        record.stages.total = elapsed_ms(start);
        const RecognitionCounts& counts = described->counts;
        ordered_json json = {{"scene", scene_name},
                             {"status", "ok"},
                             {"scene_points", counts.scene_points},
                             {"scene_points_used", counts.scene_points_used},
                             {"scene_keypoints", counts.scene_keypoints}};
        ordered_json timings = {{"read", read_ms}};
        if (placement) {
            json["placement"] = ordered_json::parse(to_json(*placement));
            timings["place"] = placement->ms;
        }
        timings["describe"] = described->timings.total;
        timings["models"] = model_ms;
        timings["total"] = record.stages.total;
        json["models"] = models;
        json["timings_ms"] = timings;
        record.line = record_line(json);
        record.ok = true;
        return record;
    } catch (const Error& e) {
        error = e.what();
    } catch (const std::bad_alloc&) {
        error = scene_name + ": out of memory";
    } catch (const std::exception& e) {
        error = scene_name + ": internal error: " + e.what();
    }
    if (track) *track = before;
    record.instances.clear();
    record.stages.total = elapsed_ms(start);
    record.line = record_line({{"scene", scene_name}, {"status", "error"}, {"error", error}});
    return record;
}

BatchOutput::BatchOutput(const std::filesystem::path& path, bool resume) : path_(path)
{
    std::error_code status_error;
    const bool exists = std::filesystem::exists(path, status_error);
    if (exists && !resume)
        throw Error(path.string(), "exists: pass --resume to continue that batch, or remove the file");
    if (exists) {
        const std::string text = read_text_file(path);
        // A kill inside a write, or a full disk, can leave a last line without its break: that
        // scene is run again.
        const std::size_t whole = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
        if (whole < text.size()) {
            std::filesystem::resize_file(path, whole, status_error);
            if (status_error) throw Error(path.string(), "cannot cut its torn last line: " + status_error.message());
        }
        const auto records = record_lines(text.substr(0, whole), path);
        for (const auto& [scene, line] : records) done_.insert(scene);
        kept_ = records.size();
    }
    fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(path.string(), std::string("cannot open for appending: ") + std::strerror(errno));
}

BatchOutput::~BatchOutput()
{
    if (fd_ < 0) return;
    ::fdatasync(fd_);
    ::close(fd_);
}

void BatchOutput::append(const std::string& line)
{
    // One write() for the whole line: a record is in the file entirely or (after a kill) not at
    // all; only a full disk splits it, and that is an error here and a cut line on resume.
    std::size_t written = 0;
    while (written < line.size()) {
        const ssize_t n = ::write(fd_, line.data() + written, line.size() - written);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw Error(path_.string(), std::string("cannot write a record: ") + std::strerror(errno));
        written += std::size_t(n);
    }
}

BatchSummary run_batch(const BatchJob& job, BatchOutput& output, const BatchShare& share,
                       const BatchProgress& progress, std::size_t in_flight)
{
    if (share.count < 1 || share.rank < 0 || share.rank >= share.count)
        throw Error("batch", "process " + std::to_string(share.rank) + " of " + std::to_string(share.count));
    check_batch_job(job);
    const bool sequence = is_sequence(job);
    if (sequence && share.count > 1)
        throw Error("batch", "a sequence is one chain of frames, each placed from the instances of the one before: "
                             "it cannot be shared between " + std::to_string(share.count) +
                             " processes (run it in one, without mpirun)");
    BatchSummary summary;
    summary.scenes = job.scenes.size();
    for (const BatchModel& model : job.models) summary.model_names.push_back(model.name);
    summary.instances.assign(job.models.size(), 0);
    // A sequence goes through every frame in order: those done are replayed from their records
    // into the track, the others run.
    std::vector<std::size_t> todo;
    for (std::size_t i = 0; i < job.scenes.size(); ++i) {
        const bool done = output.done().count(job.scenes[i].string()) > 0;
        summary.skipped += done;
        if ((!done || sequence) && i % std::size_t(share.count) == std::size_t(share.rank)) todo.push_back(i);
    }
    std::map<std::string, std::string> kept;  // a sequence's done frames: scene, record
    if (sequence && summary.skipped > 0)
        for (auto& [scene, line] : record_lines(read_text_file(output.path()), output.path()))
            kept[scene] = std::move(line);
    PlacementTrack track;
    const std::size_t tokens =
        in_flight > 0 ? in_flight : std::size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
    const auto start = Clock::now();
    std::size_t next = 0;
    std::size_t done = summary.skipped;
    // A sequence's frames are recognised one at a time, in order (each needs the track its
    // predecessor left); the scenes of any other batch in parallel.
    tbb::parallel_pipeline(
        tokens,
        tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& control) -> std::size_t {
                                                if (next == todo.size()) {
                                                    control.stop();
                                                    return 0;
                                                }
                                                return todo[next++];
                                            }) &
            tbb::make_filter<std::size_t, std::optional<SceneRecord>>(
                sequence ? tbb::filter_mode::serial_in_order : tbb::filter_mode::parallel,
                [&](std::size_t index) -> std::optional<SceneRecord> {
                    if (!sequence) return recognize_scene(job, index);
                    const std::string scene = job.scenes[index].string();
                    if (!output.done().count(scene)) return recognize_scene(job, index, &track);
                    const auto record = kept.find(scene);
                    if (record == kept.end())
                        throw Error(output.path().string(), "frame " + scene +
                                                                " is done elsewhere: without its record here the "
                                                                "track of the frames after it cannot be rebuilt");
                    replay_record(job, record->second, track);
                    return std::nullopt;
                }) &
            tbb::make_filter<std::optional<SceneRecord>, void>(
                tbb::filter_mode::serial_in_order, [&](const std::optional<SceneRecord>& record) {
                    if (!record) return;
                    output.append(record->line);
                    summary.stages.read += record->stages.read;
                    summary.stages.place += record->stages.place;
                    summary.stages.describe += record->stages.describe;
                    summary.stages.models += record->stages.models;
                    summary.stages.total += record->stages.total;
                    if (record->ok) {
                        ++summary.recognised;
                        for (std::size_t m = 0; m < record->instances.size(); ++m)
                            summary.instances[m] += record->instances[m];
                    } else {
                        ++summary.failed;
                    }
                    if (progress) progress(++done, summary.scenes, job.scenes[record->index].string());
                }));
    summary.seconds = elapsed_ms(start) / 1000.0;
    summary.peak_memory_bytes = peak_memory_bytes();
    return summary;
}

std::string to_table(const BatchSummary& summary)
{
    using detail::format_fixed;
    using detail::group_digits;
    const std::size_t run = summary.recognised + summary.failed;
    std::vector<std::pair<std::string, std::string>> rows = {
        {"scenes", group_digits(summary.scenes) + " (" + group_digits(summary.skipped) + " already done)"},
        {"recognised", group_digits(summary.recognised)},
        {"failed", group_digits(summary.failed)},
    };
    for (std::size_t m = 0; m < summary.model_names.size(); ++m)
        rows.emplace_back("instances of " + summary.model_names[m], group_digits(summary.instances[m]));
    rows.emplace_back("time", format_fixed(summary.seconds, 1) + " s, " +
                                  format_fixed(summary.seconds > 0 ? double(run) / summary.seconds : 0.0, 2) +
                                  " scenes/s");
    // Worker time: summed over the scenes, so with several in flight it exceeds the wall time.
    const StageTimes& t = summary.stages;
    auto seconds = [](double ms) { return format_fixed(ms / 1000.0, 2) + " s"; };
    rows.emplace_back("stages (worker time)", "read " + seconds(t.read) + ", place " + seconds(t.place) +
                                                  ", describe " + seconds(t.describe) + ", models " +
                                                  seconds(t.models));
    if (summary.peak_memory_bytes > 0)
        rows.emplace_back("peak memory", format_fixed(double(summary.peak_memory_bytes) / (1024.0 * 1024.0), 0) + " MiB");
    return detail::key_value_rows(rows);
}

std::string to_json(const BatchSummary& summary)
{
    ordered_json models = ordered_json::array();
    for (std::size_t m = 0; m < summary.model_names.size(); ++m)
        models.push_back({{"model", summary.model_names[m]}, {"instances", summary.instances[m]}});
    const std::size_t run = summary.recognised + summary.failed;
    const ordered_json json = {{"scenes", summary.scenes},
                               {"skipped", summary.skipped},
                               {"recognised", summary.recognised},
                               {"failed", summary.failed},
                               {"models", models},
                               {"seconds", summary.seconds},
                               {"stages_ms",
                                {{"read", summary.stages.read},
                                 {"place", summary.stages.place},
                                 {"describe", summary.stages.describe},
                                 {"models", summary.stages.models},
                                 {"total", summary.stages.total}}},
                               {"peak_memory_bytes", summary.peak_memory_bytes},
                               {"scenes_per_second", summary.seconds > 0 ? double(run) / summary.seconds : 0.0}};
    return json.dump(2, ' ', false, ordered_json::error_handler_t::replace) + '\n';
}

}  // namespace mfpc
