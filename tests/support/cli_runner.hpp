#pragma once

// Runs the mfpc command line (MFPC_CLI_PATH) as a user would, for the tools tests.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_support.hpp"

namespace mfpc::test {

struct Result {
    int exit_code = -1;
    std::string out;
    std::string err;
};

inline std::string slurp(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// Runs `mfpc ARGS` through the shell, capturing stdout, stderr and the exit code.
inline Result run(const std::string& args)
{
    const TempDir dir;
    const auto out = dir / "stdout";
    const auto err = dir / "stderr";
    const std::string command = std::string("'") + MFPC_CLI_PATH + "' " + args + " >'" + out.string() + "' 2>'" +
                                err.string() + "' </dev/null";
    const int status = std::system(command.c_str());
    Result result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = slurp(out);
    result.err = slurp(err);
    return result;
}

inline int line_count(const std::string& text)
{
    return int(std::count(text.begin(), text.end(), '\n'));
}

}  // namespace mfpc::test
