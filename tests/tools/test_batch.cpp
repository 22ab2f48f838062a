// The batch driver: which scenes a batch sees, the output that survives a kill, and the records of
// a run over small primitive scenes with two models: each model's instances as recognize() finds
// them alone, records in input order at any number of scenes in flight, a bad file a record.
#include <fstream>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "mfpc/batch/batch.hpp"
#include "mfpc/batch/scaling.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/primitive_scene.hpp"
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
    return record;
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
    {
        const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
        BatchOutput output(batch.dir / "three.jsonl", false);
        run_batch(job, output, {}, {}, 3);
    }
    const std::vector<json> again = records_of(batch.dir / "three.jsonl");
    ASSERT_EQ(again.size(), records.size());
    for (std::size_t i = 0; i < records.size(); ++i) EXPECT_EQ(without_timings(again[i]), without_timings(records[i]));
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
    const json study = json::parse(to_json(points));
    EXPECT_DOUBLE_EQ(study["points"][0]["speedup"].get<double>(), 1.0);
    EXPECT_DOUBLE_EQ(study["points"][0]["efficiency"].get<double>(), 1.0);
    EXPECT_NEAR(study["points"][1]["efficiency"].get<double>(), study["points"][1]["speedup"].get<double>() / 2, 1e-12);
    EXPECT_THROW(to_csv({}), Error);
    EXPECT_THROW(run_scaling(batch.job, {0}, batch.dir.path()), Error);
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
