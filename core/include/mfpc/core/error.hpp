#pragma once

#include <stdexcept>
#include <string>

namespace mfpc {

// The one error type of the library. `where` names the thing that failed (a file, "file:line",
// or a config key such as "fovea.json: structures[1].outer_size"); `reason` says what is wrong
// with it. what() is "where: reason", the line the command line prints after "mfpc: ".
class Error : public std::runtime_error {
public:
    Error(std::string where, std::string reason);
    explicit Error(std::string reason);

    const std::string& where() const noexcept { return where_; }
    const std::string& reason() const noexcept { return reason_; }

private:
    std::string where_;
    std::string reason_;
};

// The shortest text that reads back as `value` ("0.01", "1e-09", "inf"), for numbers in messages:
// std::to_string prints six decimals, so a tiny value reads "0.000000" and hides the mistake.
std::string format_number(float value);
std::string format_number(double value);

// A float as the double of its shortest decimal form, for JSON output: 0.015f is written 0.015,
// not 0.014999999664723873.
double shortest_double(float value);

}  // namespace mfpc
