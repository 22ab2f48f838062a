#pragma once

// Internal to MFPC (shared by its modules, not installed).

#include <filesystem>
#include <fstream>
#include <functional>

namespace mfpc {

// Writes a file through `write` into a temporary name in the same directory and renames it over
// `path` once the stream is flushed and closed, so readers never see a half-written file. Any
// failure (the callback throwing, a stream error, the rename) removes the temporary and throws
// mfpc::Error naming `path`.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ofstream&)>& write);

}  // namespace mfpc
