#include "mfpc/core/detail/text_parse.hpp"

#include <charconv>
#include <system_error>

namespace mfpc::detail {

namespace {

std::string_view without_plus(std::string_view token)
{
    // from_chars rejects a leading '+', which other writers emit.
    if (token.size() > 1 && token.front() == '+' && token[1] != '-') token.remove_prefix(1);
    return token;
}

template <typename T>
bool parse_whole(std::string_view token, T& value)
{
    token = without_plus(token);
    if (token.empty()) return false;
    T parsed{};
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), parsed);
    if (error != std::errc() || end != token.data() + token.size()) return false;
    value = parsed;
    return true;
}

}  // namespace

bool parse_float(std::string_view token, float& value)
{
    return parse_whole(token, value);
}

bool parse_double(std::string_view token, double& value)
{
    return parse_whole(token, value);
}

bool parse_unsigned(std::string_view token, std::uint64_t& value)
{
    return parse_whole(token, value);
}

bool parse_signed(std::string_view token, std::int64_t& value)
{
    return parse_whole(token, value);
}

void split_words(std::string_view line, std::vector<std::string_view>& tokens)
{
    tokens.clear();
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
    std::size_t pos = 0;
    while (pos < line.size()) {
        while (pos < line.size() && is_space(line[pos])) ++pos;
        const std::size_t start = pos;
        while (pos < line.size() && !is_space(line[pos])) ++pos;
        if (pos > start) tokens.push_back(line.substr(start, pos - start));
    }
}

std::string quoted(std::string_view text)
{
    constexpr std::size_t longest = 60;
    std::string out = "'";
    for (std::size_t i = 0; i < text.size() && i < longest; ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        out += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
    }
    if (text.size() > longest) out += "...";
    out += "'";
    return out;
}

}  // namespace mfpc::detail
