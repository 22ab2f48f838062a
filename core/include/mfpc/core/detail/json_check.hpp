#pragma once

// Internal to MFPC (shared by its modules, not installed).

#include <string>
#include <string_view>

namespace mfpc {

// Deepest nesting of objects and arrays that a JSON input may have. The configs, ground truths and
// results MFPC reads nest 4 levels at most; the limit stops a file of millions of '[' from making
// the parser build a tree gigabytes deep.
constexpr int json_depth_limit = 64;

// Throws mfpc::Error when `json_text` is not valid JSON ("source: invalid JSON: <the parser's
// message>"), nests deeper than json_depth_limit ("source: invalid JSON: nested deeper than 64
// levels"), or repeats a key within one object ("source: structures[0].density: duplicate key";
// JSON parsers silently keep one of the two values). Every JSON reader calls it before its own
// parse, so all of them reject the same inputs with the same messages. nlohmann stays out of this
// header: it is a private dependency of each library.
void check_json_text(std::string_view json_text, const std::string& source);

// A key of a JSON document as it goes into a key path of a message: a plain name (letters, digits,
// '_' and '-', at most 60 bytes) as it is, anything else quoted with control characters shown as
// '?', so that a message stays one line and a key holding '.' or ": " cannot pose as a path.
std::string json_key_text(const std::string& key);

}  // namespace mfpc
