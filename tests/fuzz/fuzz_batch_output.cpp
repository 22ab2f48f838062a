// A batch output (JSONL) as `mfpc batch --resume` reads it back: BatchOutput::scenes_in, then
// opening it with resume (which cuts a torn last line). Asserts both see the same scenes and that
// the file they leave holds whole lines only.
#include <fstream>
#include <iterator>
#include <string>

#include "fuzz_support.hpp"
#include "mfpc/batch/batch.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("out.jsonl", data, size);
    fuzz::run([&] {
        const auto scenes = BatchOutput::scenes_in(path);
        {
            BatchOutput output(path, true);
            fuzz::check(output.done() == scenes, "resume and scenes_in see different scenes");
            fuzz::check(output.kept() >= scenes.size(), "fewer records kept than scenes");
        }
        std::ifstream in(path, std::ios::binary);
        const std::string kept{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
        fuzz::check(kept.empty() || kept.back() == '\n', "resume left a torn last line");
        fuzz::check(BatchOutput::scenes_in(path) == scenes, "the resumed file holds other scenes");
    });
    return 0;
}
