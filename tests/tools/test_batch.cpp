// The batch driver: which scenes a batch sees, the output that survives a kill, and the records of
// a run over small primitive scenes with two models: each model's instances as recognize() finds
// them alone, records in input order at any number of scenes in flight, a bad file a record. With
// automatic placement each scene is placed as place_foveae places it by hand; a sequence's frames
// follow the instances of the frames before, and resumed it writes what it writes uninterrupted.
#include <fstream>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "mfpc/batch/batch.hpp"
#include "mfpc/batch/scaling.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/primitive_scene.hpp"
#include "mfpc/simulation/synthetic_sequence.hpp"
#include "cli_runner.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using nlohmann::json;
using test::TempDir;

std::vector<json> records_of(const std::filesystem::path& path)
{
    std::vector<json> records;
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);) records.push_back(json::parse(line));
    return records;
}

// A record without its timings: what must not change with the threads or the scenes in flight.
json without_timings(json record)
{
    record.erase("timings_ms");
    if (record.contains("placement")) record["placement"].erase("ms");
    return record;
}

std::vector<std::string> lines_of(const std::filesystem::path& path)
{
    std::vector<std::string> lines;
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);) lines.push_back(line + '\n');
    return lines;
}

TEST(BatchScenes, FoldersListsGlobsInAStableOrder)
{
    const TempDir dir;
    std::filesystem::create_directories(dir / "scenes");
    for (const char* name : {"b.pcd", "a.ply", "c.pcd", "notes.txt"}) dir.write(std::string("scenes/") + name, "x");
    const std::vector<std::filesystem::path> folder = list_scenes({(dir / "scenes").string()});
    ASSERT_EQ(folder.size(), 3u);
    EXPECT_EQ(folder[0].filename(), "a.ply");
    EXPECT_EQ(folder[2].filename(), "c.pcd");

    const auto list = dir.write("list.txt", "# the night's scenes\nscenes/c.pcd\n\n  scenes/b.pcd  \r\n");
    const std::vector<std::filesystem::path> listed = list_scenes({list.string()});
    ASSERT_EQ(listed.size(), 2u);
    EXPECT_EQ(listed[0], dir / "scenes/c.pcd");  // relative to the list's folder, in its order

    const std::vector<std::filesystem::path> globbed = list_scenes({(dir / "scenes/*.pcd").string()});
    ASSERT_EQ(globbed.size(), 2u);
    EXPECT_EQ(globbed[0].filename(), "b.pcd");

    // Named twice, kept once where it first appears.
    const auto both = list_scenes({list.string(), (dir / "scenes").string()});
    ASSERT_EQ(both.size(), 3u);
    EXPECT_EQ(both[0].filename(), "c.pcd");
    EXPECT_EQ(both[2].filename(), "a.ply");

    EXPECT_THROW(list_scenes({(dir / "missing").string()}), Error);
    EXPECT_THROW(list_scenes({(dir / "scenes/*.obj").string()}), Error);
    EXPECT_THROW(list_scenes({dir.write("empty.txt", "# nothing\n").string()}), Error);
}

TEST(BatchOutput, ResumeKeepsWholeRecordsAndCutsATornOne)
{
    const TempDir dir;
    const auto out = dir / "out.jsonl";
    {
        BatchOutput output(out, false);
        EXPECT_TRUE(output.done().empty());
        output.append("{\"scene\":\"a.pcd\",\"status\":\"ok\"}\n");
        output.append("{\"scene\":\"b.pcd\",\"status\":\"error\",\"error\":\"b.pcd: bad\"}\n");
    }
    // A kill inside the third write.
    { std::ofstream(out, std::ios::app) << "{\"scene\":\"c.p"; }
    EXPECT_THROW(BatchOutput(out, false), Error);  // an earlier run is never overwritten
    {
        BatchOutput output(out, true);
        EXPECT_EQ(output.done(), (std::set<std::string>{"a.pcd", "b.pcd"}));
        EXPECT_EQ(output.kept(), 2u);
        output.append("{\"scene\":\"c.pcd\",\"status\":\"ok\"}\n");
    }
    const std::vector<json> records = records_of(out);
    ASSERT_EQ(records.size(), 3u);
    EXPECT_EQ(records[2]["scene"], "c.pcd");

    const auto other = dir.write("other.jsonl", "{\"scene\":\"a.pcd\"}\nnot a record\n");
    EXPECT_THROW(BatchOutput(other, true), Error);
}

// Three primitive scenes and a corrupt file; two models cut from the first scene's objects (so
// the first scene holds both).
struct SmallBatch {
    TempDir dir;
    BatchJob job;
    std::vector<PointCloud> clouds;

    SmallBatch()
    {
        for (std::uint32_t seed : {1u, 2u, 3u}) {
            PrimitiveSceneParams params;
            params.seed = seed;
            params.objects = 2;
            params.width = 320;
            params.height = 240;
            params.focal_length = 262.5f;
            clouds.push_back(make_primitive_scene(params).cloud);
            const auto file = dir / ("scene" + std::to_string(seed) + ".pcd");
            write_cloud(file, clouds.back(), {CloudEncoding::binary, true});  // organized, as a sensor writes it
            job.scenes.push_back(file);
        }
        job.scenes.insert(job.scenes.begin() + 1, dir.write("corrupt.pcd", "# .PCD v0.7\nVERSION 0.7\nFIELDS x\n"));
        PrimitiveSceneParams first;
        first.objects = 2;
        first.width = 320;
        first.height = 240;
        first.focal_length = 262.5f;
        const PrimitiveScene scene = make_primitive_scene(first);
        for (std::size_t s = 0; s < 2; ++s) {
            // The fovea is the object's box: its points, with a sliver of the table under it.
            const FoveatedStructure& structure = scene.fovea.structures[s];
            const Box object = structure.level_box(structure.levels);
            std::vector<std::uint32_t> inside;
            for (std::uint32_t i = 0; i < scene.cloud.size(); ++i)
                if (object.contains(scene.cloud.points[i])) inside.push_back(i);
            const PointCloud part = select(scene.cloud, inside);
            job.models.push_back({"object" + std::to_string(s), prepare_model(part, job.params.model, "object")});
        }
    }
};

// The job run again with three scenes in flight on two worker threads into `out`: the records
// given, in their order, but for the timings.
void expect_same_records_at_two_threads(const BatchJob& job, const std::filesystem::path& out,
                                        const std::vector<json>& records)
{
    {
        const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
        BatchOutput output(out, false);
        run_batch(job, output, {}, {}, 3);
    }
    const std::vector<json> again = records_of(out);
    ASSERT_EQ(again.size(), records.size());
    for (std::size_t i = 0; i < records.size(); ++i) EXPECT_EQ(without_timings(again[i]), without_timings(records[i]));
}

TEST(Batch, RecordsInOrderEachModelAsAloneAndABadFileARecord)
{
    SmallBatch batch;
    const BatchJob& job = batch.job;
    BatchSummary summary;
    {
        BatchOutput output(batch.dir / "one.jsonl", false);
        std::size_t calls = 0;
        summary = run_batch(job, output, {}, [&](std::size_t done, std::size_t total, const std::string&) {
            EXPECT_EQ(done, ++calls);
            EXPECT_EQ(total, 4u);
        }, 1);
        EXPECT_EQ(calls, 4u);
    }
    EXPECT_EQ(summary.recognised, 3u);
    EXPECT_EQ(summary.failed, 1u);
    const std::vector<json> records = records_of(batch.dir / "one.jsonl");
    ASSERT_EQ(records.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(records[i]["scene"], job.scenes[i].string());
    EXPECT_EQ(records[1]["status"], "error");
    EXPECT_NE(records[1]["error"].get<std::string>().find("corrupt.pcd"), std::string::npos);

    // Each model finds in each scene what it finds alone.
    std::size_t found = 0;
    for (std::size_t i : {0u, 2u, 3u}) {
        ASSERT_EQ(records[i]["status"], "ok") << records[i].dump();
        const PointCloud& cloud = batch.clouds[i == 0 ? 0 : i - 1];
        for (std::size_t m = 0; m < 2; ++m) {
            const RecognitionResult alone = recognize(job.models[m].model, cloud, job.params);
            const json& model = records[i]["models"][m];
            EXPECT_EQ(model["model"], job.models[m].name);
            ASSERT_EQ(model["instances"].size(), alone.instances.size()) << "scene " << i << " model " << m;
            EXPECT_EQ(model["correspondences"], alone.counts.correspondences);
            for (std::size_t k = 0; k < alone.instances.size(); ++k)
                EXPECT_EQ(model["instances"][k]["fitness"].get<float>(), alone.instances[k].fitness);
            found += alone.instances.size();
        }
    }
    EXPECT_EQ(summary.instances[0] + summary.instances[1], found);
    EXPECT_GT(found, 0u);

    // Several scenes in flight and two worker threads: the same records, in the same order.
    expect_same_records_at_two_threads(job, batch.dir / "three.jsonl", records);
}

TEST(Batch, SharesSplitTheScenesAndResumeSkipsWhatIsDone)
{
    SmallBatch batch;
    std::set<std::string> scenes;
    for (int rank = 0; rank < 2; ++rank) {
        BatchOutput output(batch.dir / ("part" + std::to_string(rank) + ".jsonl"), false);
        const BatchSummary summary = run_batch(batch.job, output, {rank, 2});
        EXPECT_EQ(summary.recognised + summary.failed, 2u);
        for (const json& record : records_of(batch.dir / ("part" + std::to_string(rank) + ".jsonl")))
            EXPECT_TRUE(scenes.insert(record["scene"].get<std::string>()).second);
    }
    EXPECT_EQ(scenes.size(), batch.job.scenes.size());

    // The first part's scenes are done; the rest are run on resume, each once.
    std::filesystem::copy_file(batch.dir / "part0.jsonl", batch.dir / "resumed.jsonl");
    BatchOutput output(batch.dir / "resumed.jsonl", true);
    const BatchSummary summary = run_batch(batch.job, output);
    EXPECT_EQ(summary.skipped, 2u);
    EXPECT_EQ(summary.recognised + summary.failed, 2u);
    EXPECT_NE(to_table(summary).find("4 (2 already done)"), std::string::npos) << to_table(summary);
    EXPECT_EQ(json::parse(to_json(summary))["skipped"], 2);
}

TEST(Batch, NeedsAModelAndAValidShare)
{
    SmallBatch batch;
    BatchOutput output(batch.dir / "x.jsonl", false);
    EXPECT_THROW(run_batch(batch.job, output, {2, 2}), Error);
    BatchJob none = batch.job;
    none.models.clear();
    EXPECT_THROW(run_batch(none, output), Error);
}

TEST(Scaling, OnePointPerThreadCountAndTheFirstIsTheReference)
{
    EXPECT_EQ(default_thread_counts(1), (std::vector<int>{1}));
    EXPECT_EQ(default_thread_counts(6), (std::vector<int>{1, 2, 4, 6}));
    EXPECT_EQ(default_thread_counts(16), (std::vector<int>{1, 2, 4, 8, 16}));

    SmallBatch batch;
    const std::vector<ScalingPoint> points = run_scaling(batch.job, {1, 2}, batch.dir.path());
    ASSERT_EQ(points.size(), 2u);
    EXPECT_EQ(points[1].threads, 2);
    for (const ScalingPoint& point : points) {
        EXPECT_EQ(point.summary.recognised, 3u);
        EXPECT_GT(point.summary.stages.describe, 0.0);
        EXPECT_GE(point.summary.stages.total, point.summary.stages.describe + point.summary.stages.models);
    }
    // Each count's records are the same but for their timings.
    const std::vector<json> one = records_of(batch.dir / "threads_1.jsonl");
    const std::vector<json> two = records_of(batch.dir / "threads_2.jsonl");
    ASSERT_EQ(one.size(), two.size());
    for (std::size_t i = 0; i < one.size(); ++i) EXPECT_EQ(without_timings(one[i]), without_timings(two[i]));

    const std::string csv = to_csv(points);
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
    EXPECT_EQ(csv.find("threads,scenes,seconds,scenes_per_second,speedup,efficiency"), 0u);
    EXPECT_NE(csv.find(",read_efficiency,place_efficiency,describe_efficiency,models_efficiency,"), std::string::npos);
    const json study = json::parse(to_json(points));
    EXPECT_EQ(study["points"][1]["stage_efficiency"]["place"], 0.0);  // nothing placed: no time to compare
    EXPECT_DOUBLE_EQ(study["points"][0]["speedup"].get<double>(), 1.0);
    EXPECT_DOUBLE_EQ(study["points"][0]["efficiency"].get<double>(), 1.0);
    EXPECT_NEAR(study["points"][1]["efficiency"].get<double>(), study["points"][1]["speedup"].get<double>() / 2, 1e-12);
    EXPECT_THROW(to_csv({}), Error);
    EXPECT_THROW(run_scaling(batch.job, {0}, batch.dir.path()), Error);
}

TEST(BatchPlacement, EachSceneIsPlacedAsByHandAndTheSameAtTwoThreads)
{
    SmallBatch batch;
    BatchJob& job = batch.job;
    job.placement = PlacementParams{};  // segments
    BatchSummary summary;
    {
        BatchOutput output(batch.dir / "one.jsonl", false);
        summary = run_batch(job, output, {}, {}, 1);
    }
    EXPECT_EQ(summary.recognised, 3u);
    EXPECT_EQ(summary.failed, 1u);
    EXPECT_GT(summary.stages.place, 0.0);
    EXPECT_GT(json::parse(to_json(summary))["stages_ms"]["place"].get<double>(), 0.0);
    const std::vector<json> records = records_of(batch.dir / "one.jsonl");
    ASSERT_EQ(records.size(), 4u);
    EXPECT_FALSE(records[1].contains("placement"));  // the corrupt file: an error record

    // Placed by hand with every model, then described once and matched: the record's instances.
    std::vector<const Model*> models;
    for (const BatchModel& model : job.models) models.push_back(&model.model);
    std::size_t structures = 0;
    for (std::size_t i : {0u, 2u, 3u}) {
        const json& record = records[i];
        ASSERT_EQ(record["status"], "ok") << record.dump();
        const PointCloud& cloud = batch.clouds[i == 0 ? 0 : i - 1];
        const PlacementResult placed = place_foveae(cloud, models, job.params, *job.placement);
        const json& placement = record.at("placement");
        EXPECT_EQ(placement["strategy"], "segments");
        EXPECT_EQ(placement["structures"], placed.config.structures.size());
        EXPECT_EQ(placement["clusters"], placed.clusters);
        EXPECT_EQ(placement["fallback"].is_null(), placed.fallback.empty());
        EXPECT_TRUE(record["timings_ms"].contains("place"));
        structures += placed.config.structures.size();
        const bool foveated = !placed.config.structures.empty();
        const std::vector<RecognitionResult> alone =
            recognize_models(models, cloud, job.params, {foveated ? &placed.config : nullptr,
                                                         foveated ? FoveationMode::mfpc : FoveationMode::none, 0});
        EXPECT_EQ(record["scene_points_used"], alone[0].counts.scene_points_used);
        for (std::size_t m = 0; m < models.size(); ++m) {
            const json& model = record["models"][m];
            ASSERT_EQ(model["instances"].size(), alone[m].instances.size()) << "scene " << i << " model " << m;
            EXPECT_EQ(model["correspondences"], alone[m].counts.correspondences);
            for (std::size_t k = 0; k < alone[m].instances.size(); ++k)
                EXPECT_EQ(model["instances"][k]["fitness"].get<float>(), alone[m].instances[k].fitness);
        }
    }
    EXPECT_GT(structures, 0u);  // the objects on the table were placed

    // Two worker threads, three scenes in flight: the same records.
    expect_same_records_at_two_threads(job, batch.dir / "two.jsonl", records);
}

TEST(BatchPlacement, ContradictoryJobsAreRefused)
{
    SmallBatch batch;
    BatchOutput output(batch.dir / "x.jsonl", false);
    BatchJob both = batch.job;
    const FoveationConfig fovea;
    both.fovea = &fovea;
    both.placement = PlacementParams{};
    EXPECT_THROW(run_batch(both, output), Error);
    EXPECT_THROW(recognize_scene(both, 0), Error);
    BatchJob oracle = batch.job;
    oracle.placement = PlacementParams{};
    oracle.placement->strategy = PlacementStrategy::oracle;
    EXPECT_THROW(run_batch(oracle, output), Error);
    BatchJob bad = batch.job;
    bad.placement = PlacementParams{};
    bad.placement->levels = 0;
    EXPECT_THROW(run_batch(bad, output), Error);
    // A track goes with a sequence, and a sequence's frame needs one.
    PlacementTrack track;
    BatchJob segments = batch.job;
    segments.placement = PlacementParams{};
    EXPECT_THROW(recognize_scene(segments, 0, &track), Error);
    BatchJob sequence = batch.job;
    sequence.placement = PlacementParams{};
    sequence.placement->strategy = PlacementStrategy::track;
    EXPECT_TRUE(is_sequence(sequence));
    EXPECT_FALSE(is_sequence(segments));
    EXPECT_THROW(recognize_scene(sequence, 0), Error);
    EXPECT_THROW(run_batch(sequence, output, {0, 2}), Error);  // one chain: not shared between processes
    EXPECT_TRUE(records_of(batch.dir / "x.jsonl").empty());
}

// A short synthetic sequence (the camera turning 3 degrees a frame around 2 cartons and a
// distractor), written once for the sequence tests.
class BatchSequence : public ::testing::Test {
protected:
    static void SetUpTestSuite()
    {
        dir_ = new test::TempDir;
        ComposeParams compose;
        compose.seed = 3;
        compose.objects = 2;
        compose.distractors = 1;
        SensorParams sensor;
        sensor.width = 320;
        sensor.height = 240;
        write_synthetic_sequence(dir_->path(), builtin_scene_shapes(), compose, sensor, {4, 9.0f});
    }
    static void TearDownTestSuite()
    {
        delete dir_;
        dir_ = nullptr;
    }
    static const std::filesystem::path& dir() { return dir_->path(); }
    static BatchJob job()
    {
        BatchJob job;
        job.scenes = list_scenes({(dir() / "frames.txt").string()});
        job.models.push_back({"carton", read_model_cache(dir() / "carton.mfpcm")});
        job.placement = PlacementParams{};
        job.placement->strategy = PlacementStrategy::track;
        return job;
    }

    static test::TempDir* dir_;
};

test::TempDir* BatchSequence::dir_ = nullptr;

TEST_F(BatchSequence, FramesFollowTheInstancesOfTheFramesBefore)
{
    const BatchJob job = BatchSequence::job();
    ASSERT_EQ(job.scenes.size(), 4u);
    {
        const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
        BatchOutput output(dir() / "seq.jsonl", false);
        const BatchSummary summary = run_batch(job, output);
        EXPECT_EQ(summary.recognised, 4u);
        EXPECT_GT(summary.stages.place, 0.0);
    }
    const std::vector<json> records = records_of(dir() / "seq.jsonl");
    ASSERT_EQ(records.size(), 4u);
    ASSERT_FALSE(records[0]["models"][0]["instances"].empty()) << records[0].dump();

    // By hand: one track carried along the frames, told each frame's instances.
    PlacementTrack track;
    std::vector<const Model*> models = {&job.models[0].model};
    for (std::size_t i = 0; i < records.size(); ++i) {
        const json& record = records[i];
        EXPECT_EQ(record["scene"], job.scenes[i].string());
        const json& placement = record.at("placement");
        EXPECT_EQ(placement["strategy"], "track");
        if (i == 0) {
            EXPECT_EQ(placement["followed"], 0);
            EXPECT_TRUE(placement["searched"].get<bool>());  // nothing followed yet: a search
        } else {
            EXPECT_GT(placement["followed"].get<int>(), 0) << "frame " << i;
            EXPECT_FALSE(placement["searched"].get<bool>());  // the next search is due at frame 10
        }
        const PointCloud cloud = read_cloud(job.scenes[i]);
        const PlacementResult placed = place_foveae(cloud, models, job.params, *job.placement, {}, &track);
        EXPECT_EQ(placement["structures"], placed.config.structures.size()) << "frame " << i;
        EXPECT_EQ(placement["followed"], placed.followed) << "frame " << i;
        const bool foveated = !placed.config.structures.empty();
        const RecognitionResult result =
            recognize(*models[0], cloud, job.params,
                      {foveated ? &placed.config : nullptr, foveated ? FoveationMode::mfpc : FoveationMode::none, 0});
        ASSERT_EQ(record["models"][0]["instances"].size(), result.instances.size()) << "frame " << i;
        std::vector<PlacedInstance> found;
        for (const Instance& instance : result.instances) found.push_back({0, instance.transform});
        track_update(track, models, found, job.placement->track_refresh);
    }

    // Killed after two frames and resumed (on one thread): the track is rebuilt from their records,
    // and the last frames' records are those of the uninterrupted run.
    const std::vector<std::string> lines = lines_of(dir() / "seq.jsonl");
    {
        std::ofstream part(dir() / "resumed.jsonl");
        part << lines[0] << lines[1];
    }
    {
        const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
        BatchOutput output(dir() / "resumed.jsonl", true);
        const BatchSummary summary = run_batch(job, output);
        EXPECT_EQ(summary.skipped, 2u);
        EXPECT_EQ(summary.recognised, 2u);
    }
    const std::vector<json> resumed = records_of(dir() / "resumed.jsonl");
    ASSERT_EQ(resumed.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(without_timings(resumed[i]), without_timings(records[i])) << i;

    // A record naming a model the job lacks cannot be replayed.
    PlacementTrack replayed;
    BatchJob other = job;
    other.models[0].name = "other";
    EXPECT_THROW(replay_record(other, lines[0], replayed), Error);
    replay_record(job, lines[0], replayed);
    EXPECT_EQ(replayed.frame, 1u);
    EXPECT_EQ(replayed.followed.size(), records[0]["models"][0]["instances"].size());
}

// `mfpc batch --fovea auto` and `--sequence` as a user runs them: each scene's instances as
// `mfpc recognize --fovea auto` finds them, the frames followed, contradictions refused (exit 2).
TEST_F(BatchSequence, CliPlacesEachSceneOrFollowsTheFrames)
{
    const std::string base = "--threads 2 -q batch --model " + test::quoted(dir() / "carton.mfpcm") + " --scenes " +
                             test::quoted(dir() / "frames.txt") + " -o ";
    const auto placed = dir() / "cli_auto.jsonl";
    const test::Result automatic = test::run(base + test::quoted(placed) + " --fovea auto --json -");
    ASSERT_EQ(automatic.exit_code, 0) << automatic.err;
    EXPECT_GT(json::parse(automatic.out)["stages_ms"]["place"].get<double>(), 0.0);
    const std::vector<json> records = records_of(placed);
    ASSERT_EQ(records.size(), 4u);
    for (std::size_t i : {0u, 3u}) {
        EXPECT_EQ(records[i]["placement"]["strategy"], "segments");
        const test::Result alone = test::run("--threads 2 -q --json - recognize --fovea auto --model " +
                                             test::quoted(dir() / "carton.mfpcm") + " --scene " +
                                             test::quoted(records[i]["scene"].get<std::string>()));
        ASSERT_EQ(alone.exit_code, 0) << alone.err;
        const json report = json::parse(alone.out);
        const json& instances = records[i]["models"][0]["instances"];
        ASSERT_EQ(instances.size(), report["instances"].size()) << alone.out;
        for (std::size_t k = 0; k < instances.size(); ++k)
            EXPECT_EQ(instances[k]["transform"], report["instances"][k]["transform"]);
    }

    const auto sequence = dir() / "cli_seq.jsonl";
    const test::Result followed = test::run(base + test::quoted(sequence) + " --sequence");
    ASSERT_EQ(followed.exit_code, 0) << followed.err;
    const std::vector<json> frames = records_of(sequence);
    ASSERT_EQ(frames.size(), 4u);
    for (const json& frame : frames) EXPECT_EQ(frame["placement"]["strategy"], "track");
    EXPECT_GT(frames[1]["placement"]["followed"].get<int>(), 0);

    const auto refused = dir() / "refused.jsonl";
    for (const std::string& options :
         {"--sequence --fovea " + test::quoted(dir() / "frame_000/fovea.json"), std::string("--sequence --placement grid"),
          std::string("--placement coarse"), std::string("--fovea auto --placement track"),
          std::string("--fovea auto --placement oracle"), std::string("--fovea auto --placement nearest")})
        test::expect_one_line_error(test::run(base + test::quoted(refused) + " " + options), 2, options);
    EXPECT_FALSE(std::filesystem::exists(refused));
}

// `mfpc batch` as a user meets it: a bad file among the scenes is a record and exit status 3; an
// earlier output is never overwritten; killed with SIGKILL in the middle and resumed, every scene
// is there exactly once.
TEST(CliBatch, ABadSceneIsARecordAndAKilledBatchResumes)
{
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    MFPC_SHARED_FILE_OR_SKIP(model, "milk.pcd");
    const TempDir dir;
    std::filesystem::create_directories(dir / "scenes");
    for (int i = 0; i < 8; ++i)
        std::filesystem::create_hard_link(scene, dir / "scenes" / ("scene" + std::to_string(i) + ".pcd"));
    dir.write("scenes/scene3b.pcd", "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n");
    const auto out = dir / "out.jsonl";
    const std::string batch = "--threads 2 -q batch --model " + test::quoted(model) + " --scenes " +
                              test::quoted(dir / "scenes") + " -o " + test::quoted(out);

    // Killed as soon as the first record is written.
    const std::string kill_script = "(" + std::string("'") + MFPC_CLI_PATH + "' " + batch +
                                    " >/dev/null 2>&1 & pid=$!; while [ ! -s " + test::quoted(out).c_str() +
                                    " ]; do sleep 0.02; done; kill -9 $pid; wait $pid) 2>/dev/null";
    std::system(kill_script.c_str());
    const std::size_t before = records_of(out).size();
    EXPECT_GE(before, 1u);
    EXPECT_LT(before, 9u);

    test::expect_one_line_error(test::run(batch), 1, "an existing output without --resume");
    const test::Result resumed = test::run(batch + " --resume");
    EXPECT_EQ(resumed.exit_code, 3) << resumed.err;  // the bad file, whenever it was reached
    const std::vector<json> records = records_of(out);
    ASSERT_EQ(records.size(), 9u);
    std::set<std::string> scenes;
    for (const json& record : records) {
        EXPECT_TRUE(scenes.insert(record["scene"].get<std::string>()).second) << record["scene"];
        const bool bad = record["scene"].get<std::string>().ends_with("scene3b.pcd");
        EXPECT_EQ(record["status"], bad ? "error" : "ok");
        if (!bad) {
            EXPECT_EQ(record["models"][0]["instances"].size(), 2u);
        }
    }
}

}  // namespace
}  // namespace mfpc
