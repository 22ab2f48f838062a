#pragma once

// Internal to MFPC (shared by its modules, not installed).

namespace mfpc {

// floor(v) as an integer of type Int, written out because on baseline x86-64 std::floor is a
// library call, which dominated the loops that bucket points into cells. Exact while v lies
// within Int's range; callers bound it.
template <class Int, class Real>
inline Int floor_to(Real v)
{
    const Int t = static_cast<Int>(v);
    return t - Int(Real(t) > v);
}

}  // namespace mfpc
