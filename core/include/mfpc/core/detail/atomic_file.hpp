#pragma once

// Internal to MFPC (shared by its modules, not installed).

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace mfpc {

// Writes a file through `write` into a temporary name in the same directory and renames it over
// `path` once the stream is flushed and closed, so readers never see a half-written file. Any
// failure (the callback throwing, a stream error, the rename) removes the temporary and throws
// mfpc::Error naming `path`.
//
// Temporaries are named PATH.tmp-HOST-PID-RANDOM. A process killed while writing cannot remove
// its own, so the first write of a process into a directory removes the temporaries there that a
// process of this host no longer running left behind.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ofstream&)>& write);

// Several outputs of one command, written all or none: stage() writes each to its temporary (as
// write_file_atomically does), commit() renames them all over their targets. A failure before
// commit(), or the object destroyed without it, removes every temporary and leaves every target
// as it was; a rename failing inside commit() puts back the targets already replaced.
class StagedFiles {
public:
    StagedFiles() = default;
    StagedFiles(const StagedFiles&) = delete;
    StagedFiles& operator=(const StagedFiles&) = delete;
    ~StagedFiles();

    void stage(const std::filesystem::path& path, const std::function<void(std::ofstream&)>& write);
    void stage(const std::filesystem::path& path, const std::string& bytes);
    void commit();
    // Removes every temporary not committed (what the destructor does), so the caller can clean
    // up around them before it returns.
    void discard();

private:
    struct Staged {
        std::filesystem::path target;
        std::filesystem::path temporary;
    };
    std::vector<Staged> staged_;
};

}  // namespace mfpc
