#include "mfpc/core/detail/atomic_file.hpp"

#include <exception>
#include <random>
#include <string>
#include <system_error>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// A name beside `path` that no other writer picks: a random suffix, so two processes writing the
// same file do not share a temporary.
std::filesystem::path temporary_name(const std::filesystem::path& path)
{
    static constexpr char digits[] = "0123456789abcdef";
    std::random_device random;
    std::string suffix = ".tmp-";
    for (int i = 0; i < 4; ++i) {
        const unsigned value = random();
        for (int nibble = 0; nibble < 4; ++nibble) suffix += digits[(value >> (4 * nibble)) & 0xfu];
    }
    std::filesystem::path name = path;
    name += suffix;
    return name;
}

void remove_quietly(const std::filesystem::path& path)
{
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ofstream&)>& write)
{
    const std::string where = path.string();
    if (path.filename().empty()) throw Error(where, "not a file name");
    const std::filesystem::path directory = path.parent_path().empty() ? "." : path.parent_path();
    std::error_code status_error;
    if (!std::filesystem::is_directory(directory, status_error)) {
        throw Error(where, "directory " + directory.string() + " does not exist");
    }
    if (std::filesystem::is_directory(path, status_error)) throw Error(where, "is a directory");

    const std::filesystem::path temporary = temporary_name(path);
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(where, "cannot create " + temporary.string() + " (directory not writable?)");
    try {
        write(out);
        out.flush();
        if (!out) throw Error(where, "writing " + temporary.string() + " failed (disk full?)");
        out.close();
        if (!out) throw Error(where, "closing " + temporary.string() + " failed (disk full?)");
    } catch (const Error&) {
        out.close();
        remove_quietly(temporary);
        throw;
    } catch (const std::exception& error) {
        out.close();
        remove_quietly(temporary);
        throw Error(where, error.what());
    } catch (...) {
        out.close();
        remove_quietly(temporary);
        throw Error(where, "writing failed with an unknown exception");
    }
    std::error_code rename_error;
    std::filesystem::rename(temporary, path, rename_error);
    if (rename_error) {
        remove_quietly(temporary);
        throw Error(where, "cannot rename " + temporary.string() + " over it: " + rename_error.message());
    }
}

}  // namespace mfpc
