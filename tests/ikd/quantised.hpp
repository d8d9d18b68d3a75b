// tests/ikd/quantised.hpp -- a uint8 / uint16 volume quantised from a float field, for the tests
// that render a grid natively and as its float32 copy.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include <sylva/volume/grid.hpp>

namespace sylva::test {

/// A uint8 or uint16 volume quantised from the float field `g`, with the value range [lo, hi]
/// (uint16: a range narrower than the type, so values beyond it clamp).
inline volume::Volume quantised(const volume::DensityGrid& g, volume::ScalarType type, float lo, float hi) {
    volume::Volume v;
    v.type = type;
    v.dims = g.dims;
    v.spacing = g.spacing;
    v.range_lo = lo;
    v.range_hi = hi;
    std::size_t b = volume::scalar_bytes(type);
    v.bytes.resize(g.values.size() * b);
    float top = type == volume::ScalarType::U8 ? 255.0f : 65535.0f;
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        auto q = static_cast<std::uint32_t>(std::lround(g.values[i] * top));
        std::memcpy(&v.bytes[i * b], &q, b);  // little endian: the low bytes
    }
    return v;
}

}  // namespace sylva::test
