#include <glob.h>

#include <algorithm>
#include <set>
#include <sstream>

#include "mfpc/batch/batch.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc {
namespace {

bool is_cloud_file(const std::filesystem::path& path)
{
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
    return extension == ".pcd" || extension == ".ply";
}

bool is_glob(const std::string& spec) { return spec.find_first_of("*?[") != std::string::npos; }

std::vector<std::filesystem::path> folder_scenes(const std::filesystem::path& folder)
{
    std::vector<std::filesystem::path> scenes;
    std::error_code error;
    for (std::filesystem::directory_iterator it(folder, error), end; !error && it != end; it.increment(error))
        if (it->is_regular_file(error) && is_cloud_file(it->path())) scenes.push_back(it->path());
    if (error) throw Error(folder.string(), "cannot list the folder: " + error.message());
    std::sort(scenes.begin(), scenes.end());
    return scenes;
}

std::vector<std::filesystem::path> listed_scenes(const std::filesystem::path& list)
{
    std::vector<std::filesystem::path> scenes;
    std::istringstream lines(read_text_file(list));
    for (std::string line; std::getline(lines, line);) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::size_t first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        const std::size_t last = line.find_last_not_of(" \t");
        const std::filesystem::path scene(line.substr(first, last - first + 1));
        scenes.push_back(scene.is_absolute() ? scene : list.parent_path() / scene);
    }
    return scenes;
}

std::vector<std::filesystem::path> globbed_scenes(const std::string& pattern)
{
    glob_t matches{};
    const int status = ::glob(pattern.c_str(), GLOB_ERR, nullptr, &matches);
    std::vector<std::filesystem::path> scenes;
    if (status == 0)
        for (std::size_t i = 0; i < matches.gl_pathc; ++i) scenes.emplace_back(matches.gl_pathv[i]);
    ::globfree(&matches);
    if (status == GLOB_NOMATCH) throw Error(pattern, "the pattern matches no file");
    if (status != 0) throw Error(pattern, "cannot expand the pattern (a folder could not be read)");
    return scenes;  // glob(3) sorts its matches
}

}  // namespace

std::vector<std::filesystem::path> list_scenes(const std::vector<std::string>& specs)
{
    std::vector<std::filesystem::path> scenes;
    std::set<std::filesystem::path> seen;
    for (const std::string& spec : specs) {
        std::error_code error;
        const std::filesystem::path path(spec);
        std::vector<std::filesystem::path> found;
        if (std::filesystem::is_directory(path, error)) found = folder_scenes(path);
        else if (is_cloud_file(path) && !is_glob(spec)) found = {path};
        else if (std::filesystem::is_regular_file(path, error)) found = listed_scenes(path);
        else if (is_glob(spec)) found = globbed_scenes(spec);
        else throw Error(spec, "no such file or folder");
        for (std::filesystem::path& scene : found)
            if (seen.insert(scene.lexically_normal()).second) scenes.push_back(std::move(scene));
    }
    if (scenes.empty()) throw Error("batch", "no scene to recognise in " + std::to_string(specs.size()) + " --scenes");
    return scenes;
}

}  // namespace mfpc
