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

// A path as one shell word.
inline std::string quoted(const std::filesystem::path& path) { return "'" + path.string() + "'"; }

// The house rule for failures: exit `code`, and one line on stderr starting "mfpc: ".
inline void expect_one_line_error(const Result& r, int code, const std::string& what)
{
    EXPECT_EQ(r.exit_code, code) << what << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("mfpc: ", 0), 0u) << what << "\n" << r.err;
    EXPECT_EQ(line_count(r.err), 1) << what << "\n" << r.err;
}

}  // namespace mfpc::test
