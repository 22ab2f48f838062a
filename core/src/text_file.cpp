#include "mfpc/core/detail/text_file.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "mfpc/core/error.hpp"

namespace mfpc {

std::string read_text_file(const std::filesystem::path& path)
{
    const std::string where = path.string();
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    // status() reports ENOENT and ENOTDIR as not_found; any other failure (EACCES, ELOOP,
    // ENAMETOOLONG) leaves the type unknown, and "no such file" would then be a wrong guess.
    if (status.type() == std::filesystem::file_type::not_found) throw Error(where, "no such file");
    if (error) throw Error(where, error.message());
    if (std::filesystem::is_directory(status)) throw Error(where, "is a directory");
    if (!std::filesystem::is_regular_file(status)) throw Error(where, "not a regular file");
    const std::uintmax_t size = std::filesystem::file_size(path, error);
    if (error) throw Error(where, "cannot read its size: " + error.message());

    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(where, std::string("cannot open for reading: ") + std::strerror(errno));
    // Sized from the file so that every later bound can be checked against the real size.
    std::string bytes(size, '\0');
    in.read(bytes.data(), static_cast<std::streamsize>(size));
    if (static_cast<std::uintmax_t>(in.gcount()) != size) {
        throw Error(where, "read only " + std::to_string(in.gcount()) + " of " + std::to_string(size) + " bytes");
    }
    return bytes;
}

}  // namespace mfpc
