#include "mfpc/core/detail/atomic_file.hpp"

#include <cerrno>
#include <charconv>
#include <exception>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <string_view>
#include <system_error>

#include <signal.h>
#include <unistd.h>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

constexpr std::string_view temporary_marker = ".tmp-";

// This host's name as it goes into a temporary's name: letters, digits and '_' only, so that the
// '-' fields of the name can be split again.
const std::string& host_tag()
{
    static const std::string tag = [] {
        char name[256] = {};
        if (gethostname(name, sizeof name - 1) != 0) return std::string("host");
        std::string out;
        for (const char* c = name; *c != '\0' && out.size() < 32; ++c) {
            const bool plain = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9');
            out += plain ? *c : '_';
        }
        return out.empty() ? std::string("host") : out;
    }();
    return tag;
}

// A name beside `path` that no other writer picks: host, process and a random suffix, so two
// processes writing the same file do not share a temporary, and a later run can tell whose it was.
std::filesystem::path temporary_name(const std::filesystem::path& path)
{
    static constexpr char digits[] = "0123456789abcdef";
    std::random_device random;
    std::string suffix = std::string(temporary_marker) + host_tag() + "-" + std::to_string(getpid()) + "-";
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

// Whether `name` is a temporary that a process of this host left and that is gone: NAME.tmp-HOST-
// PID-RANDOM with this host, and no process PID. A PID since reused only delays the cleanup.
bool abandoned_temporary(std::string_view name)
{
    const std::size_t marker = name.rfind(temporary_marker);
    if (marker == std::string_view::npos) return false;
    std::string_view rest = name.substr(marker + temporary_marker.size());
    const std::string& host = host_tag();
    if (rest.size() <= host.size() || rest.substr(0, host.size()) != host || rest[host.size()] != '-') return false;
    rest.remove_prefix(host.size() + 1);
    const std::size_t dash = rest.find('-');
    if (dash == std::string_view::npos) return false;
    // RANDOM is 16 hex digits, ".old" after them on a target kept by StagedFiles::commit().
    const std::string_view random = rest.substr(dash + 1);
    if (random.size() != 16 && !(random.size() == 20 && random.substr(16) == ".old")) return false;
    long pid = 0;
    const auto [end, error] = std::from_chars(rest.data(), rest.data() + dash, pid);
    if (error != std::errc() || end != rest.data() + dash || pid <= 0) return false;
    if (pid == long(getpid())) return false;
    return kill(pid_t(pid), 0) != 0 && errno == ESRCH;
}

// Once per directory and process: removes what abandoned_temporary() finds there.
void remove_abandoned_temporaries(const std::filesystem::path& directory)
{
    static std::mutex mutex;
    static std::set<std::filesystem::path> cleaned;
    {
        const std::lock_guard lock(mutex);
        if (!cleaned.insert(directory).second) return;
    }
    std::error_code error;
    for (std::filesystem::directory_iterator it(directory, error), end; !error && it != end; it.increment(error)) {
        const std::string name = it->path().filename().string();
        if (name.find(temporary_marker) != std::string::npos && abandoned_temporary(name)) remove_quietly(it->path());
    }
}

// Checks the target, then writes `write`'s output to a fresh temporary beside it and returns its
// name; on any failure the temporary is gone and an Error names `path`.
std::filesystem::path write_temporary(const std::filesystem::path& path, const std::function<void(std::ofstream&)>& write)
{
    const std::string where = path.string();
    if (path.filename().empty()) throw Error(where, "not a file name");
    const std::filesystem::path directory = path.parent_path().empty() ? "." : path.parent_path();
    std::error_code status_error;
    if (!std::filesystem::is_directory(directory, status_error)) {
        throw Error(where, "directory " + directory.string() + " does not exist");
    }
    if (std::filesystem::is_directory(path, status_error)) throw Error(where, "is a directory");
    remove_abandoned_temporaries(directory);

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
    return temporary;
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ofstream&)>& write)
{
    const std::filesystem::path temporary = write_temporary(path, write);
    std::error_code rename_error;
    std::filesystem::rename(temporary, path, rename_error);
    if (rename_error) {
        remove_quietly(temporary);
        throw Error(path.string(), "cannot rename " + temporary.string() + " over it: " + rename_error.message());
    }
}

StagedFiles::~StagedFiles() { discard(); }

void StagedFiles::discard()
{
    for (const Staged& file : staged_) remove_quietly(file.temporary);
    staged_.clear();
}

void StagedFiles::stage(const std::filesystem::path& path, const std::function<void(std::ofstream&)>& write)
{
    staged_.push_back({path, write_temporary(path, write)});
}

void StagedFiles::stage(const std::filesystem::path& path, const std::string& bytes)
{
    stage(path, [&](std::ofstream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); });
}

void StagedFiles::commit()
{
    // Each target that exists is kept under a second name (a hard link, no copy) until every
    // rename has succeeded, so that a failing one can put the earlier ones back.
    std::vector<std::filesystem::path> kept(staged_.size());
    std::vector<bool> existed(staged_.size(), false);
    const auto drop_kept = [&] {
        for (const std::filesystem::path& k : kept)
            if (!k.empty()) remove_quietly(k);
    };
    for (std::size_t i = 0; i < staged_.size(); ++i) {
        std::error_code error;
        if (!std::filesystem::exists(staged_[i].target, error)) continue;
        existed[i] = true;
        std::filesystem::path keep = staged_[i].temporary;
        keep += ".old";
        std::filesystem::create_hard_link(staged_[i].target, keep, error);
        if (!error) kept[i] = keep;
    }
    for (std::size_t i = 0; i < staged_.size(); ++i) {
        std::error_code error;
        std::filesystem::rename(staged_[i].temporary, staged_[i].target, error);
        if (!error) continue;
        const std::string reason = "cannot rename " + staged_[i].temporary.string() + " over it: " + error.message();
        for (std::size_t j = 0; j < i; ++j) {
            std::error_code ignored;
            if (!kept[j].empty()) std::filesystem::rename(kept[j], staged_[j].target, ignored);
            else if (!existed[j]) std::filesystem::remove(staged_[j].target, ignored);
            // (an old target that could not be kept stays replaced: nothing else can be done)
        }
        drop_kept();
        const std::filesystem::path target = staged_[i].target;
        staged_.erase(staged_.begin(), staged_.begin() + std::ptrdiff_t(i));  // renamed away: nothing to remove
        discard();
        throw Error(target.string(), reason);
    }
    drop_kept();
    staged_.clear();
}

}  // namespace mfpc
