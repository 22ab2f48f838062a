#include "mfpc/core/error.hpp"

#include <charconv>
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

std::string format_number(float value)
{
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    return std::string(buffer, result.ptr);
}

std::string format_number(double value)
{
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    return std::string(buffer, result.ptr);
}

double shortest_double(float value)
{
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
    double out = 0.0;
    std::from_chars(buffer, end, out);
    return out;
}

}  // namespace mfpc
