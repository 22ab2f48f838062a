#include <cerrno>
#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>
#include <sys/stat.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::TempDir;

// The reason read_text_file gives for `path`, after checking that the message is one line naming
// the path; "" (and a failure) when the file reads.
std::string reason_of(const std::filesystem::path& path)
{
    try {
        read_text_file(path);
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), path.string());
        EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos) << error.what();
        return error.reason();
    }
    ADD_FAILURE() << path << " was read without an error";
    return {};
}

TEST(TextFile, ReadsEveryByteAsItIs)
{
    TempDir dir;
    const std::string bytes("line\r\nzero \0 byte\n\xff", 19);
    EXPECT_EQ(read_text_file(dir.write("bytes.txt", bytes)), bytes);
    EXPECT_EQ(read_text_file(dir.write("empty.txt", "")), "");
}

TEST(TextFile, NamesEachFileSystemProblem)
{
    TempDir dir;
    EXPECT_EQ(reason_of(dir / "absent.json"), "no such file");
    // ENOTDIR (a file where a folder should be) also means the file is not there.
    EXPECT_EQ(reason_of(dir.write("plain", "x") / "below.json"), "no such file");
    std::filesystem::create_directory(dir / "folder.json");
    EXPECT_EQ(reason_of(dir / "folder.json"), "is a directory");
    // A FIFO would block the reader until someone writes to it.
    ASSERT_EQ(mkfifo((dir / "fifo.json").c_str(), 0600), 0);
    EXPECT_EQ(reason_of(dir / "fifo.json"), "not a regular file");
}

// When the file system cannot say what the path is, its own reason is reported rather than a
// guess of "no such file".
TEST(TextFile, ReportsTheSystemReasonWhenThePathCannotBeExamined)
{
    TempDir dir;
    EXPECT_EQ(reason_of(dir / std::string(300, 'n')), std::generic_category().message(ENAMETOOLONG));
    std::filesystem::create_symlink(dir / "loop_b", dir / "loop_a");
    std::filesystem::create_symlink(dir / "loop_a", dir / "loop_b");
    EXPECT_EQ(reason_of(dir / "loop_a"), std::generic_category().message(ELOOP));
}

TEST(TextFile, ReportsAFolderItMayNotEnter)
{
    TempDir dir;
    std::filesystem::create_directory(dir / "closed");
    const auto file = dir.write("closed/config.json", "{}");
    std::filesystem::permissions(dir / "closed", std::filesystem::perms::none);
    std::error_code error;
    if (std::filesystem::exists(file, error)) {
        std::filesystem::permissions(dir / "closed", std::filesystem::perms::owner_all);
        GTEST_SKIP() << "permissions are not enforced for this user (root)";
    }
    EXPECT_EQ(reason_of(file), std::generic_category().message(EACCES));
    std::filesystem::permissions(dir / "closed", std::filesystem::perms::owner_all);  // so TempDir can clean up
}

}  // namespace
}  // namespace mfpc
