#include "mfpc/core/peak_memory.hpp"

#include <charconv>
#include <fstream>
#include <string>

#include <sys/resource.h>

namespace mfpc {

bool reset_peak_memory()
{
    // Writing 5 to clear_refs resets VmHWM (Linux 4.0 on); the rest of the file is left alone.
    std::ofstream refs("/proc/self/clear_refs");
    if (!refs) return false;
    refs << "5";
    refs.flush();
    return bool(refs);
}

std::size_t peak_memory_bytes()
{
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);) {
        if (line.rfind("VmHWM:", 0) != 0) continue;
        // "VmHWM:     1234 kB"
        const std::size_t digits = line.find_first_of("0123456789");
        std::size_t kilobytes = 0;
        if (digits == std::string::npos ||
            std::from_chars(line.data() + digits, line.data() + line.size(), kilobytes).ec != std::errc())
            break;
        return kilobytes * 1024;
    }
    // No /proc: getrusage's peak, which cannot be reset (kilobytes on Linux and the BSDs).
    rusage usage{};
    if (getrusage(RUSAGE_SELF, &usage) == 0) return std::size_t(usage.ru_maxrss) * 1024;
    return 0;
}

}  // namespace mfpc
