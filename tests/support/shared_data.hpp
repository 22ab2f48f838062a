#pragma once

#include <cstdlib>
#include <filesystem>

namespace mfpc::test {

// The folder of shared real clouds (../shared/data beside the checkout, or MFPC_DATA_DIR when set),
// for tests and benchmarks alike.
inline std::filesystem::path shared_data_dir()
{
    if (const char* dir = std::getenv("MFPC_DATA_DIR")) return dir;
    return MFPC_SHARED_DATA_DIR;
}

}  // namespace mfpc::test
