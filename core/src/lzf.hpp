#pragma once

// LZF, the compression inside PCD's binary_compressed data (PCL writes it with liblzf). Private to
// the core module: the PCD reader and writer are its only users.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mfpc::detail {

// Decompresses `compressed` into exactly `out.size()` bytes. Corrupt input (a run or back-reference
// reaching past either buffer, a block that ends early or decompresses to a different size) throws
// mfpc::Error(where, reason); nothing is read or written outside the two spans.
void lzf_decompress(std::span<const std::uint8_t> compressed, std::span<std::uint8_t> out, const std::string& where);

// Compresses `data` into a block that lzf_decompress (and liblzf) restores exactly. Incompressible
// input grows by at most one byte in 32 (+1). `data` must be under 4 GiB, as PCD's uint32 block
// sizes require anyway.
std::vector<std::uint8_t> lzf_compress(std::span<const std::uint8_t> data);

}  // namespace mfpc::detail
