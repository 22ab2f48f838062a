#include "lzf.hpp"

#include <algorithm>
#include <cstring>

#include "mfpc/core/error.hpp"

namespace mfpc::detail {

// The LZF stream is a sequence of chunks, each starting with a control byte:
//   ctrl < 32  : a literal run, the next ctrl + 1 bytes are copied as they are;
//   ctrl >= 32 : a back-reference; length = ctrl >> 5, and when that is 7 the next byte is added
//                to it; the byte after that completes the distance ((ctrl & 0x1f) << 8 | byte) + 1;
//                length + 2 bytes are copied from `distance` bytes back in the output (the source
//                may overlap the bytes being written, which repeats a short pattern).
namespace {

constexpr std::size_t max_literal_run = 32;
constexpr std::size_t max_distance = 8192;         // 13 bits of distance - 1
constexpr std::size_t max_match = 7 + 255 + 2;     // longest length a back-reference can say
constexpr std::size_t min_match = 3;               // a shorter match costs as much as literals
constexpr int hash_bits = 14;

Error corrupt(const std::string& where, const std::string& detail)
{
    return Error(where, "compressed data is corrupt (" + detail + ")");
}

std::uint32_t hash_of_three(const std::uint8_t* bytes)
{
    const std::uint32_t v = std::uint32_t(bytes[0]) << 16 | std::uint32_t(bytes[1]) << 8 | bytes[2];
    return (v * 2654435761u) >> (32 - hash_bits);
}

void append_literals(std::vector<std::uint8_t>& out, const std::uint8_t* begin, std::size_t count)
{
    while (count > 0) {
        const std::size_t run = std::min(count, max_literal_run);
        out.push_back(static_cast<std::uint8_t>(run - 1));
        out.insert(out.end(), begin, begin + run);
        begin += run;
        count -= run;
    }
}

}  // namespace

void lzf_decompress(std::span<const std::uint8_t> compressed, std::span<std::uint8_t> out, const std::string& where)
{
    const std::size_t in_size = compressed.size();
    const std::size_t out_size = out.size();
    std::size_t in_pos = 0;
    std::size_t out_pos = 0;
    const auto too_long = [&] {
        return Error(where, "compressed data is corrupt (it decompresses to more than the " +
                                std::to_string(out_size) + " bytes announced)");
    };
    while (in_pos < in_size) {
        const std::size_t chunk_start = in_pos;
        const unsigned control = compressed[in_pos++];
        if (control < 32) {
            const std::size_t run = control + 1;
            if (run > in_size - in_pos) {
                throw corrupt(where, "literal run at byte " + std::to_string(chunk_start) + " reaches past the end");
            }
            if (run > out_size - out_pos) throw too_long();
            // A fixed 32-byte copy (two vector moves) where both buffers have the room beyond the
            // run, rather than a call sized at run time: literal runs are the commonest chunk.
            if (in_size - in_pos >= max_literal_run && out_size - out_pos >= max_literal_run) {
                std::memcpy(out.data() + out_pos, compressed.data() + in_pos, max_literal_run);
            } else {
                std::memcpy(out.data() + out_pos, compressed.data() + in_pos, run);
            }
            in_pos += run;
            out_pos += run;
            continue;
        }
        std::size_t length = control >> 5;
        if (length == 7) {
            if (in_pos >= in_size) {
                throw corrupt(where, "back-reference at byte " + std::to_string(chunk_start) + " is cut off");
            }
            length += compressed[in_pos++];
        }
        if (in_pos >= in_size) {
            throw corrupt(where, "back-reference at byte " + std::to_string(chunk_start) + " is cut off");
        }
        const std::size_t distance = ((std::size_t(control & 0x1fu) << 8) | compressed[in_pos++]) + 1;
        length += 2;
        if (distance > out_pos) {
            throw corrupt(where, "back-reference at byte " + std::to_string(chunk_start) +
                                     " points before the start of the data");
        }
        if (length > out_size - out_pos) throw too_long();
        // When distance < length the copy overlaps its own output and repeats the last `distance`
        // bytes. Copying one period and then doubling the copied span keeps every memcpy free of
        // overlap (each chunk is no longer than the gap to its source) in O(log length) calls;
        // long runs of one repeated value (NaN padding of organized clouds) are common.
        std::uint8_t* target = out.data() + out_pos;
        if (distance >= 16 && out_size - out_pos >= length + 16) {
            // Sources at least 16 bytes back: 16-byte copies in order never read a byte this
            // reference has yet to write (each ends at or before its own target).
            for (std::size_t copied = 0; copied < length; copied += 16) std::memcpy(target + copied, target + copied - distance, 16);
            out_pos += length;
            continue;
        }
        if (16 % distance == 0 && out_size - out_pos >= length + 16) {
            // A period dividing 16 (runs of one float, NaN padding above all): 16 bytes of the
            // pattern, stored as often as the run needs.
            std::uint8_t pattern[16];
            for (std::size_t i = 0; i < 16; ++i) pattern[i] = target[std::ptrdiff_t(i % distance) - std::ptrdiff_t(distance)];
            for (std::size_t stored = 0; stored < length; stored += 16) std::memcpy(target + stored, pattern, 16);
            out_pos += length;
            continue;
        }
        std::size_t copied = std::min(distance, length);
        std::memcpy(target, target - distance, copied);
        while (copied < length) {
            const std::size_t chunk = std::min(copied, length - copied);
            std::memcpy(target + copied, target, chunk);
            copied += chunk;
        }
        out_pos += length;
    }
    if (out_pos != out_size) {
        throw corrupt(where, "it decompresses to " + std::to_string(out_pos) + " bytes, " + std::to_string(out_size) +
                                 " announced");
    }
}

std::vector<std::uint8_t> lzf_compress(std::span<const std::uint8_t> data)
{
    const std::size_t size = data.size();
    const std::uint8_t* bytes = data.data();
    std::vector<std::uint8_t> out;
    out.reserve(size + size / max_literal_run + 1);
    // Last position (+1, so 0 means none) where each hash of three bytes was seen.
    std::vector<std::uint32_t> last_seen(std::size_t(1) << hash_bits, 0);

    std::size_t literal_start = 0;
    std::size_t pos = 0;
    while (pos + min_match <= size) {
        const std::uint32_t hash = hash_of_three(bytes + pos);
        const std::size_t candidate_plus_one = last_seen[hash];
        last_seen[hash] = static_cast<std::uint32_t>(pos + 1);
        if (candidate_plus_one == 0) {
            ++pos;
            continue;
        }
        const std::size_t candidate = candidate_plus_one - 1;
        const std::size_t distance = pos - candidate;
        if (distance > max_distance || std::memcmp(bytes + candidate, bytes + pos, min_match) != 0) {
            ++pos;
            continue;
        }
        const std::size_t longest = std::min(max_match, size - pos);
        std::size_t length = min_match;
        while (length < longest && bytes[candidate + length] == bytes[pos + length]) ++length;

        append_literals(out, bytes + literal_start, pos - literal_start);
        const std::size_t stored_length = length - 2;
        const std::size_t stored_distance = distance - 1;
        if (stored_length < 7) {
            out.push_back(static_cast<std::uint8_t>(stored_length << 5 | stored_distance >> 8));
        } else {
            out.push_back(static_cast<std::uint8_t>(7u << 5 | stored_distance >> 8));
            out.push_back(static_cast<std::uint8_t>(stored_length - 7));
        }
        out.push_back(static_cast<std::uint8_t>(stored_distance & 0xffu));
        // Remember the positions inside the match too, so a long run keeps finding itself.
        const std::size_t match_end = pos + length;
        for (++pos; pos < match_end && pos + min_match <= size; ++pos) {
            last_seen[hash_of_three(bytes + pos)] = static_cast<std::uint32_t>(pos + 1);
        }
        pos = match_end;
        literal_start = pos;
    }
    append_literals(out, bytes + literal_start, size - literal_start);
    return out;
}

}  // namespace mfpc::detail
