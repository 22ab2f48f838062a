#pragma once

// Private to recognition: the key checks the experiment config and the dataset manifest share, and
// the one way every report of the library writes its JSON.
// Key paths follow one convention: `where` ends in ": " at a document's root ("set.json: ") and in
// "." below it ("set.json: scenes[2]."), so where + key names the key.

#include <algorithm>
#include <initializer_list>
#include <string>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"

namespace mfpc::detail {

// Throws for a value that is not an object or holds a key not in `allowed`. Here `where` names the
// object itself: "set.json: " at the root, "set.json: scenes[2]" below.
inline void check_keys(const nlohmann::json& object, const std::string& where,
                       std::initializer_list<const char*> allowed)
{
    if (!object.is_object())
        throw Error(where.ends_with(": ") ? where.substr(0, where.size() - 2) : where, "must be a JSON object");
    for (const auto& item : object.items()) {
        if (std::none_of(allowed.begin(), allowed.end(), [&](const char* key) { return item.key() == key; }))
            throw Error(where + (where.ends_with(": ") ? "" : ".") + json_key_text(item.key()), "unknown key");
    }
}

// The non-empty string at `key`; empty when absent and not `required`.
inline std::string text_of(const nlohmann::json& object, const char* key, const std::string& where, bool required)
{
    const auto it = object.find(key);
    if (it == object.end()) {
        if (required) throw Error(where + key, "missing");
        return {};
    }
    if (!it->is_string() || it->get<std::string>().empty()) throw Error(where + key, "must be a non-empty string");
    return it->get<std::string>();
}

// The document as indented JSON text with a final newline. Strings that are not UTF-8 (a file name
// in another encoding, which a file system allows) get U+FFFD for their bad bytes instead of
// failing the whole report after the work is done.
inline std::string json_text(const nlohmann::ordered_json& document)
{
    return document.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + '\n';
}

}  // namespace mfpc::detail
