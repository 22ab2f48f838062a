#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "shared_data.hpp"

namespace mfpc::test {

// The path of a shared cloud; the calling test is skipped, saying which file is missing, when it
// is absent (CI and developers have it; a bare checkout may not).
#define MFPC_SHARED_FILE_OR_SKIP(var, name)                                                         \
    const std::filesystem::path var = ::mfpc::test::shared_data_dir() / (name);                     \
    if (!std::filesystem::exists(var)) GTEST_SKIP() << "shared data file " << var << " is absent"

// A fresh directory under the system temp dir, removed when the object goes away.
class TempDir {
public:
    TempDir()
    {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string name = "mfpc-test-";
        if (info) name += std::string(info->test_suite_name()) + "-" + info->name() + "-";
        name += std::to_string(std::random_device{}());
        for (char& c : name) {
            if (c == '/') c = '_';
        }
        path_ = std::filesystem::temp_directory_path() / name;
        std::filesystem::create_directories(path_);
    }
    ~TempDir()
    {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& path() const { return path_; }
    std::filesystem::path operator/(std::string_view name) const { return path_ / name; }

    // Writes bytes to a file in this directory and returns its path.
    std::filesystem::path write(std::string_view name, std::string_view bytes) const
    {
        const auto file = path_ / name;
        std::ofstream out(file, std::ios::binary);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        return file;
    }

private:
    std::filesystem::path path_;
};

}  // namespace mfpc::test
