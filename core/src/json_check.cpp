#include "mfpc/core/detail/json_check.hpp"

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cloud_format.hpp"  // quoted
#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

using nlohmann::json;

// Reads the document as events only (nlohmann's SAX interface): no tree is built, so the check
// costs no memory beyond the open containers. Rejects duplicate keys (nlohmann's own parser keeps
// the last one silently) and names them by their key path; stops at the depth limit. `frames` is
// the stack of open objects and arrays, enough to spell the path of the value being read.
class JsonTextCheck : public nlohmann::json_sax<json> {
public:
    explicit JsonTextCheck(const std::string& source) : source_(source) {}

    bool null() override { return value(); }
    bool boolean(bool) override { return value(); }
    bool number_integer(number_integer_t) override { return value(); }
    bool number_unsigned(number_unsigned_t) override { return value(); }
    bool number_float(number_float_t, const string_t&) override { return value(); }
    bool string(string_t&) override { return value(); }
    bool binary(binary_t&) override { return value(); }
    bool start_object(std::size_t) override { return open(false); }
    bool start_array(std::size_t) override { return open(true); }
    bool end_object() override { return close(); }
    bool end_array() override { return close(); }

    bool key(string_t& key) override
    {
        Frame& frame = frames_.back();
        frame.key = key;
        if (!frame.seen.insert(frame.key).second) throw Error(source_ + ": " + path(), "duplicate key");
        return true;
    }

    // A syntax error, or a number beyond double ("1e999"): nlohmann's message reads
    // "[json.exception.parse_error.101] parse error at line 3, ...": keep the part a person needs.
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& error) override
    {
        std::string message = error.what();
        if (const auto start = message.find("] "); start != std::string::npos) message.erase(0, start + 2);
        throw Error(source_, "invalid JSON: " + message);
    }

private:
    struct Frame {
        bool array;
        std::size_t count;  // elements seen so far (arrays)
        std::string key;    // the key being read (objects)
        std::set<std::string> seen;
    };

    bool value()
    {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().count;
        return true;
    }

    bool open(bool array)
    {
        // The containers already open around this one: the top level is at depth 0.
        if (frames_.size() >= std::size_t(json_depth_limit)) {
            throw Error(source_, "invalid JSON: nested deeper than " + std::to_string(json_depth_limit) + " levels");
        }
        value();
        frames_.push_back({array, 0, {}, {}});
        return true;
    }

    bool close()
    {
        frames_.pop_back();
        return true;
    }

    std::string path() const
    {
        std::string text;
        for (const Frame& frame : frames_) {
            if (frame.array) {
                text += "[" + std::to_string(frame.count - 1) + "]";
            } else {
                if (!text.empty()) text += ".";
                text += json_key_text(frame.key);
            }
        }
        return text;
    }

    const std::string& source_;
    std::vector<Frame> frames_;
};

}  // namespace

void check_json_text(std::string_view json_text, const std::string& source)
{
    JsonTextCheck check(source);
    json::sax_parse(json_text.begin(), json_text.end(), &check);
}

std::string json_key_text(const std::string& key)
{
    const bool plain = !key.empty() && key.size() <= 60 && std::all_of(key.begin(), key.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    return plain ? key : detail::quoted(key);
}

}  // namespace mfpc
