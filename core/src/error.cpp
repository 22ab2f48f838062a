#include "mfpc/core/error.hpp"

#include <utility>

namespace mfpc {

namespace {
std::string join(const std::string& where, const std::string& reason)
{
    return where.empty() ? reason : where + ": " + reason;
}
}  // namespace

Error::Error(std::string where, std::string reason)
    : std::runtime_error(join(where, reason)), where_(std::move(where)), reason_(std::move(reason))
{
}

Error::Error(std::string reason) : Error(std::string(), std::move(reason)) {}

}  // namespace mfpc
