// sylva/vulkan/split_words.hpp -- word arrays larger than one storage buffer binding, split over
// several buffers. The GLSL side is sylva/shared/split_words.glsl (SYLVA_SPLIT_WORDS).
#ifndef SYLVA_VULKAN_SPLIT_WORDS_HPP
#define SYLVA_VULKAN_SPLIT_WORDS_HPP

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/buffer.hpp"
#include "sylva/vulkan/context.hpp"

namespace sylva::vk {

/// The most words per part that split_words chooses by itself: 2^25 words = 128 MiB.
inline constexpr std::uint32_t max_split_shift = 25;

/// A word array split into parts of 2^shift words: word i lives in parts[i >> shift] at index
/// i & ((1 << shift) - 1). Parts past the data are 4-byte dummies so that all can be bound.
struct SplitWords {
    std::uint32_t shift = 0;    ///< log2 of the words per part; pass it to the shader (SYLVA_SPLIT_WORDS).
    std::vector<Buffer> parts;  ///< Bind these at consecutive bindings, in order.

    /// Pointers to the parts, in order, for Context::dispatch (append the kernel's other buffers).
    [[nodiscard]] std::vector<Buffer*> bindings() {
        std::vector<Buffer*> pointers;
        pointers.reserve(parts.size());
        for (Buffer& part : parts) pointers.push_back(&part);
        return pointers;
    }
};

/// How many parts of 2^shift words `words` words fill (at least 1): the PARTS specialization
/// constant of SYLVA_SPLIT_WORDS_COUNTED (1 lets the shader skip the part selection).
inline std::uint32_t used_parts(std::size_t words, std::uint32_t shift) {
    std::size_t part = std::size_t{1} << shift;
    return static_cast<std::uint32_t>(std::max<std::size_t>(1, (words + part - 1) / part));
}

/// The largest shift whose part (2^shift words) fits one storage buffer binding of the device,
/// capped at max_split_shift.
inline std::uint32_t default_split_shift(const Context& context) {
    const std::size_t max_words = context.max_storage_buffer_range() / sizeof(std::uint32_t);
    std::uint32_t shift = 0;
    while (shift < max_split_shift && (std::size_t{1} << (shift + 1)) <= max_words) ++shift;
    return shift;
}

/// Uploads `words` into `parts` storage buffers of 2^shift words each (the last used part only as
/// long as needed). shift == 0 chooses default_split_shift(context). Throws sylva::Error when the
/// words do not fit into `parts` parts or a part would exceed the device's binding range.
inline SplitWords split_words(Context& context, std::span<const std::uint32_t> words, std::uint32_t parts = 4,
                              std::uint32_t shift = 0) {
    if (parts == 0) throw Error("split_words: needs at least one part");
    if (shift == 0) shift = default_split_shift(context);
    if (shift > 31 || (std::uint64_t{4} << shift) > context.max_storage_buffer_range()) {
        throw Error("split_words: parts of 2^" + std::to_string(shift) + " words exceed the device's " +
                    "maxStorageBufferRange of " + std::to_string(context.max_storage_buffer_range()) + " bytes");
    }
    const std::uint64_t part_words = std::uint64_t{1} << shift;
    if (words.size() > part_words * parts) {
        throw Error("split_words: " + std::to_string(words.size()) + " words do not fit into " + std::to_string(parts) +
                    " parts of 2^" + std::to_string(shift) + " words");
    }
    SplitWords split;
    split.shift = shift;
    split.parts.reserve(parts);
    for (std::uint32_t p = 0; p < parts; ++p) {
        const std::uint64_t first = part_words * p;
        const std::size_t count =
            first < words.size() ? static_cast<std::size_t>(std::min<std::uint64_t>(part_words, words.size() - first))
                                 : 0;
        split.parts.emplace_back(context, count * sizeof(std::uint32_t));
        if (count > 0) split.parts.back().upload(words.subspan(static_cast<std::size_t>(first), count));
    }
    return split;
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_SPLIT_WORDS_HPP
