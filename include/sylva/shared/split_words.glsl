// sylva/shared/split_words.glsl -- GLSL only: a word array split over four storage buffers, the
// shader side of sylva::vk::split_words (include/sylva/vulkan/split_words.hpp).
//
// Usage, before including any shared header that reads the buffer NAME:
//
//   layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;   // or any constant expression
//   SYLVA_SPLIT_WORDS(nodes, 0, SPLIT_SHIFT)                 // bindings 0, 1, 2, 3
//   ... uint w = sylva_load_nodes(i);                        // or SYLVA_LOAD(nodes, i) in shared code
//
// Word i lives in part i >> SHIFT at index i & ((1 << SHIFT) - 1), as split_words uploads it.
// Reads past the end of a part (or of a dummy part) return 0, like sylva::shared::Words on the host.
#ifndef SYLVA_SHARED_SPLIT_WORDS_GLSL
#define SYLVA_SHARED_SPLIT_WORDS_GLSL

/// One readonly std430 block of the split array NAME at BINDING; PART is 0..3.
#define SYLVA_SPLIT_WORDS_PART(NAME, BINDING, PART) \
    layout(std430, binding = (BINDING)) readonly buffer sylva_split_##NAME##_block##PART { \
        uint sylva_split_##NAME##_##PART[]; \
    };

/// Reads index J of part PART of NAME, 0 past its end.
#define SYLVA_SPLIT_WORDS_READ(NAME, PART, J) \
    ((J) < uint(sylva_split_##NAME##_##PART.length()) ? sylva_split_##NAME##_##PART[(J)] : 0u)

/// Declares the four parts of NAME at bindings FIRST_BINDING..FIRST_BINDING+3 and defines
/// `uint sylva_load_NAME(uint i)`, which selects the part by i >> SHIFT.
#define SYLVA_SPLIT_WORDS(NAME, FIRST_BINDING, SHIFT) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 0, 0) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 1, 1) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 2, 2) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 3, 3) \
    uint sylva_load_##NAME(uint i) { \
        uint part = i >> (SHIFT); \
        uint j = i & ((1u << (SHIFT)) - 1u); \
        if (part == 0u) return SYLVA_SPLIT_WORDS_READ(NAME, 0, j); \
        if (part == 1u) return SYLVA_SPLIT_WORDS_READ(NAME, 1, j); \
        if (part == 2u) return SYLVA_SPLIT_WORDS_READ(NAME, 2, j); \
        if (part == 3u) return SYLVA_SPLIT_WORDS_READ(NAME, 3, j); \
        return 0u; \
    }

/// SYLVA_SPLIT_WORDS with a specialization constant PARTS: the number of parts that hold data
/// (1 to 4: the word count divided by 2^SHIFT, rounded up). When it is 1 (arrays up to 2^SHIFT words, the
/// common case) every load reads part 0 directly: on lavapipe that makes a shader reading the
/// array in its inner loop about three times faster than the four-way part selection.
#define SYLVA_SPLIT_WORDS_COUNTED(NAME, FIRST_BINDING, SHIFT, PARTS) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 0, 0) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 1, 1) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 2, 2) \
    SYLVA_SPLIT_WORDS_PART(NAME, (FIRST_BINDING) + 3, 3) \
    uint sylva_load_##NAME(uint i) { \
        if ((PARTS) <= 1u) return SYLVA_SPLIT_WORDS_READ(NAME, 0, i); \
        uint part = i >> (SHIFT); \
        uint j = i & ((1u << (SHIFT)) - 1u); \
        if (part == 0u) return SYLVA_SPLIT_WORDS_READ(NAME, 0, j); \
        if (part == 1u) return SYLVA_SPLIT_WORDS_READ(NAME, 1, j); \
        if (part == 2u) return SYLVA_SPLIT_WORDS_READ(NAME, 2, j); \
        if (part == 3u) return SYLVA_SPLIT_WORDS_READ(NAME, 3, j); \
        return 0u; \
    }

#endif  // SYLVA_SHARED_SPLIT_WORDS_GLSL
