#pragma once
// What the fuzz targets share: a per-process scratch folder for readers that take a path, a reader
// of fuzzed bytes for the library-level targets, the checks that make a wrong answer a finding, and
// the known-finding switches.
//
// A finding is an abort: a failed check, an ASan/UBSan report, or any exception other than
// mfpc::Error escaping the library (libFuzzer reports it as a deadly signal after std::terminate).
// mfpc::Error is the library saying no to bad input, which is the expected outcome: run() swallows
// it and nothing else.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <unistd.h>

#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::fuzz {

/// One worker thread: a fuzzer runs one input after another on one core (scripts/fuzz.sh runs the
/// targets one at a time beside other work), the kernels are bit-identical at any thread count,
/// and a finding then replays the same way.
inline const tbb::global_control one_thread{tbb::global_control::max_allowed_parallelism, 1};

/// A finding: prints what failed and aborts, so libFuzzer keeps the input as a reproducer and the
/// replay test fails.
[[noreturn]] inline void fail(const std::string& what)
{
    std::fprintf(stderr, "fuzz check failed: %s\n", what.c_str());
    std::fflush(stderr);
    std::abort();
}

inline void check(bool condition, const char* what)
{
    if (!condition) fail(what);
}

/// Runs `body`; only mfpc::Error may leave the library, and it means the input was refused.
template <class Body>
void run(Body&& body)
{
    try {
        body();
    } catch (const mfpc::Error&) {
    }
}

/// A folder of this process's own, under /dev/shm when there is one (no disk writes per run),
/// else $TMPDIR or /tmp; removed at exit.
inline const std::filesystem::path& scratch_dir()
{
    static const std::filesystem::path dir = [] {
        std::filesystem::path base = "/dev/shm";
        std::error_code error;
        if (!std::filesystem::is_directory(base, error)) {
            const char* tmp = std::getenv("TMPDIR");
            base = tmp && *tmp ? tmp : "/tmp";
        }
        std::filesystem::path made = base / ("mfpc-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(made);
        static const std::filesystem::path removed_at_exit = made;
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(removed_at_exit, ignored);
        });
        return made;
    }();
    return dir;
}

/// Writes `size` bytes to `name` in the scratch folder and returns its path.
inline std::filesystem::path write_input(const std::string& name, const void* data, std::size_t size)
{
    const std::filesystem::path path = scratch_dir() / name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) fail("cannot write the scratch file " + path.string());
    return path;
}

/// Reads fuzzed bytes front to back; past the end every value is 0, so any input is a valid one.
class Bytes {
public:
    Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

    std::size_t left() const { return size_ - position_; }

    std::uint8_t byte() { return position_ < size_ ? data_[position_++] : 0; }

    std::uint16_t u16() { return std::uint16_t(byte() | (byte() << 8)); }

    std::uint32_t u32() { return std::uint32_t(u16()) | (std::uint32_t(u16()) << 16); }

    /// An integer in [low, high].
    int in(int low, int high) { return low + int(u16() % std::uint32_t(high - low + 1)); }

    /// A number on a grid of `steps` + 1 values from `low` to `high`: fuzzed clouds on a grid put
    /// points exactly on box faces and on top of each other, where the edge cases live.
    float grid(float low, float high, int steps = 64) { return low + (high - low) * float(in(0, steps)) / float(steps); }

    /// Any float bit pattern (NaN and Inf included).
    float raw_float()
    {
        const std::uint32_t bits = u32();
        float value;
        std::memcpy(&value, &bits, sizeof value);
        return value;
    }

private:
    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t position_ = 0;
};

inline bool finite(const Point& p) { return p.allFinite(); }

/// Whether to skip inputs that reach a known open finding (issue 32) so a target can go on finding
/// new ones. MFPC_FUZZ_KNOWN=1 in the environment runs them anyway, to see whether a finding is
/// still open.
inline bool skip_known_findings()
{
    static const bool skip = [] {
        const char* value = std::getenv("MFPC_FUZZ_KNOWN");
        return !(value && std::string_view(value) == "1");
    }();
    return skip;
}

}  // namespace mfpc::fuzz
