// list_scenes (mfpc batch --scenes) on a fuzzed scene list: one path or glob a line, relative to
// the list's folder (the scratch folder, which holds two clouds the globs can match). Asserts every
// scene is listed once.
#include <set>

#include "fuzz_support.hpp"
#include "mfpc/batch/batch.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    static const bool clouds_written = [] {
        const char cloud[] = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n0 0 1\n";
        fuzz::write_input("a.ply", cloud, sizeof cloud - 1);
        fuzz::write_input("b.ply", cloud, sizeof cloud - 1);
        return true;
    }();
    (void)clouds_written;
    const auto path = fuzz::write_input("scenes.txt", data, size);
    fuzz::run([&] {
        const auto scenes = list_scenes({path.string()});
        fuzz::check(!scenes.empty(), "list_scenes returned no scene");
        std::set<std::filesystem::path> seen;
        for (const auto& scene : scenes) fuzz::check(seen.insert(scene).second, "a scene is listed twice");
    });
    return 0;
}
