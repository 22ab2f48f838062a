#pragma once

// Internal (not installed): the scalar types of PCD fields and PLY properties, shared by the
// cloud readers in core and the mesh reader in tools/simulation.

#include <cstddef>
#include <cstdint>

namespace mfpc::detail {

enum class ScalarType : std::uint8_t { int8, uint8, int16, uint16, int32, uint32, int64, uint64, float32, float64 };

// Inline: binary readers ask for every value they step over.
constexpr std::size_t size_of(ScalarType type)
{
    switch (type) {
    case ScalarType::int8:
    case ScalarType::uint8: return 1;
    case ScalarType::int16:
    case ScalarType::uint16: return 2;
    case ScalarType::int32:
    case ScalarType::uint32:
    case ScalarType::float32: return 4;
    case ScalarType::int64:
    case ScalarType::uint64:
    case ScalarType::float64: return 8;
    }
    return 0;
}

constexpr bool is_integer(ScalarType type)
{
    return type != ScalarType::float32 && type != ScalarType::float64;
}

}  // namespace mfpc::detail
