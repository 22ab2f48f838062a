#pragma once

/// @file
/// @brief mfpc::Error, the one error type of the library, and numbers written for messages.

#include <stdexcept>
#include <string>

namespace mfpc {

/// @brief The one error type of the library.
///
/// `where` names the thing that failed (a file, "file:line", or a config key such as
/// "fovea.json: structures[1].outer_size"); `reason` says what is wrong with it. what() is
/// "where: reason", the line the command line prints after "mfpc: ".
class Error : public std::runtime_error {
public:
    /// @brief An error in `where`.
    /// @param where The thing that failed: a file, "file:line" or a config key.
    /// @param reason What is wrong with it.
    Error(std::string where, std::string reason);
    /// @brief An error not tied to a place: where() is empty and what() is the reason alone.
    /// @param reason What is wrong.
    explicit Error(std::string reason);

    /// @brief The thing that failed.
    /// @return A file, "file:line" or a config key; empty when not given.
    const std::string& where() const noexcept { return where_; }
    /// @brief What is wrong with it.
    /// @return The reason, without the place.
    const std::string& reason() const noexcept { return reason_; }

private:
    std::string where_;
    std::string reason_;
};

/// @brief The shortest text that reads back as `value` ("0.01", "1e-09", "inf"), for numbers in
/// messages: std::to_string prints six decimals, so a tiny value reads "0.000000" and hides the
/// mistake.
/// @param value The number.
/// @return Its shortest round-trip text.
std::string format_number(float value);
/// @brief The shortest text that reads back as `value`, as format_number(float).
/// @param value The number.
/// @return Its shortest round-trip text.
std::string format_number(double value);

/// @brief A float as the double of its shortest decimal form, for JSON output: 0.015f is written
/// 0.015, not 0.014999999664723873.
/// @param value The float.
/// @return The double nearest the shortest decimal that reads back as `value`.
double shortest_double(float value);

}  // namespace mfpc
