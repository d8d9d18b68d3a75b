// sylva/bih/payload.hpp -- leaf payload encoders (how a leaf's elements pack into 62 bits).
#ifndef SYLVA_BIH_PAYLOAD_HPP
#define SYLVA_BIH_PAYLOAD_HPP

#include <cstdint>
#include <span>

#include "sylva/core/concepts.hpp"
#include "sylva/shared/bih_layout.h"

namespace sylva::bih {

/// The general payload: the leaf's range in the tree's element order.
/// Bits 0-31: index of the first element; bits 32-61: element count.
struct RangePayload {
    static constexpr std::uint32_t kind = SYLVA_PAYLOAD_RANGE;
    template <Bounded E>
    [[nodiscard]] std::uint64_t encode(std::span<const E> leaf, std::uint32_t first) const {
        return std::uint64_t{first} | (std::uint64_t{static_cast<std::uint32_t>(leaf.size())} << 32);
    }
};

/// Unpacks a RangePayload: (first, count).
inline std::pair<std::uint32_t, std::uint32_t> decode_range(std::uint64_t payload) {
    return {static_cast<std::uint32_t>(payload), static_cast<std::uint32_t>(payload >> 32)};
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_PAYLOAD_HPP
