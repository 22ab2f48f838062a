// parse_recognition_params on fuzzed JSON. Asserts that accepted parameters pass
// check_recognition_params and that to_json writes a text that parses to the same parameters
// (the same JSON once more).
#include <string>
#include <string_view>

#include "fuzz_support.hpp"
#include "mfpc/recognition/params.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    fuzz::run([&] {
        const RecognitionParams params = parse_recognition_params(text, "fuzz.json");
        try {
            check_recognition_params(params, "fuzz.json");
            const std::string json = to_json(params);
            const std::string again = to_json(parse_recognition_params(json, "to_json"));
            fuzz::check(again == json, "recognition params change when written and read back");
        } catch (const Error& error) {
            fuzz::fail(std::string("accepted recognition params do not check or read back: ") + error.what());
        }
    });
    return 0;
}
