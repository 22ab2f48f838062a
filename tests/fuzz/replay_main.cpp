// The main of the replay build (no libFuzzer): feeds every file of the directories (or the files)
// given on the command line to LLVMFuzzerTestOneInput, in name order, so CTest can run each fuzz
// target over its seed corpus and its crash reproducers. A missing directory counts as empty: a
// target with no reproducer yet has no regressions/<target>/ folder.
//
// A folder's open-findings.txt names, one a line (after it, '#' and why), the reproducers of
// findings not fixed yet: they are listed and skipped, so the suite passes while the fix is open and
// the reproducer is already in place; deleting the line makes it a regression test.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <system_error>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv)
{
    namespace fs = std::filesystem;
    std::vector<fs::path> inputs;
    std::set<fs::path> open;
    for (int i = 1; i < argc; ++i) {
        const fs::path path = argv[i];
        std::error_code error;
        if (fs::is_directory(path, error)) {
            std::ifstream list(path / "open-findings.txt");
            for (std::string line; std::getline(list, line);) {
                const std::string name = line.substr(0, line.find_first_of(" \t#"));
                if (!name.empty()) open.insert(path / name);
            }
            for (const auto& entry : fs::recursive_directory_iterator(path)) {
                // README files and the open list explain a folder; they are no input.
                const fs::path name = entry.path().filename();
                if (entry.is_regular_file() && name != "README.md" && name != "open-findings.txt") {
                    inputs.push_back(entry.path());
                }
            }
        } else if (fs::is_regular_file(path, error)) {
            inputs.push_back(path);
        } else {
            std::printf("replay: %s: none\n", path.c_str());
        }
    }
    std::sort(inputs.begin(), inputs.end());
    std::size_t skipped = 0;
    for (const fs::path& path : inputs) {
        if (open.count(path)) {
            std::printf("replay: %s: open finding, skipped\n", path.c_str());
            ++skipped;
            continue;
        }
        std::ifstream in(path, std::ios::binary);
        const std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
        if (!in.eof() && in.fail()) {
            std::fprintf(stderr, "replay: %s: cannot read\n", path.c_str());
            return 1;
        }
        // Printed before the run, so a crash names its input.
        std::printf("replay: %s (%zu bytes)\n", path.c_str(), bytes.size());
        std::fflush(stdout);
        LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    }
    std::printf("replay: %zu inputs passed, %zu open findings skipped\n", inputs.size() - skipped, skipped);
    return 0;
}
