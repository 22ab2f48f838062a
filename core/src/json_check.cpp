#include "mfpc/core/json_check.hpp"

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

// Rejects duplicate keys while parsing (nlohmann would silently keep the last one) and names them
// by their key path; stops at the depth limit before the parser builds anything deeper. The
// callback sees the document as a stream of events; `frames` is the stack of open objects and
// arrays, enough to spell the path of the value being read.
class JsonTextCheck {
public:
    explicit JsonTextCheck(const std::string& source) : source_(source) {}

    bool operator()(int depth, json::parse_event_t event, json& parsed)
    {
        switch (event) {
        case json::parse_event_t::object_start:
        case json::parse_event_t::array_start:
            // `depth` counts the containers around this one: the top level is 0.
            if (depth >= json_depth_limit) {
                throw Error(source_, "invalid JSON: nested deeper than " + std::to_string(json_depth_limit) +
                                         " levels");
            }
            enter_element();
            frames_.push_back({event == json::parse_event_t::array_start, 0, {}, {}});
            break;
        case json::parse_event_t::object_end:
        case json::parse_event_t::array_end:
            frames_.pop_back();
            break;
        case json::parse_event_t::key: {
            Frame& frame = frames_.back();
            frame.key = parsed.get<std::string>();
            if (!frame.seen.insert(frame.key).second) {
                throw Error(source_ + ": " + path(), "duplicate key");
            }
            break;
        }
        case json::parse_event_t::value:
            enter_element();
            break;
        }
        return true;
    }

private:
    struct Frame {
        bool array;
        std::size_t count;  // elements seen so far (arrays)
        std::string key;    // the key being read (objects)
        std::set<std::string> seen;
    };

    void enter_element()
    {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().count;
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
    try {
        // The parsed document is thrown away: the readers parse again into their own tree. Reading
        // twice costs little for these small files and keeps nlohmann out of the interface.
        [[maybe_unused]] const json document = json::parse(json_text.begin(), json_text.end(), JsonTextCheck(source));
    } catch (const json::exception& error) {
        // A syntax error (parse_error) or a number beyond double (out_of_range, "1e999").
        // nlohmann's message reads "[json.exception.parse_error.101] parse error at line 3, ...":
        // keep the part a person needs.
        std::string message = error.what();
        if (const auto start = message.find("] "); start != std::string::npos) {
            message.erase(0, start + 2);
        }
        throw Error(source, "invalid JSON: " + message);
    }
}

std::string json_key_text(const std::string& key)
{
    const bool plain = !key.empty() && key.size() <= 60 && std::all_of(key.begin(), key.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    return plain ? key : detail::quoted(key);
}

}  // namespace mfpc
