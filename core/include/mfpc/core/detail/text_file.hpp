#pragma once

// Internal to MFPC (shared by its modules, not installed).

#include <filesystem>
#include <string>

namespace mfpc {

// The whole content of a file, byte for byte (no newline translation). Throws mfpc::Error whose
// where() is the path and whose reason is "no such file", "is a directory", "not a regular file"
// (a FIFO or device could block forever), "cannot open for reading: <system message>", or the
// system's message when the file system cannot even say what the path is (e.g. "Permission
// denied" on a folder above it). One reader for every input file, so each says the same things.
std::string read_text_file(const std::filesystem::path& path);

}  // namespace mfpc
