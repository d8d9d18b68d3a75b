// sylva/octree/elements_validate.hpp -- checks an untrusted element-octree encoding
// (sylva/shared/octree_elem_iter.h) before anything traverses it, with a message that names the
// first problem. Children and neighbour pointers are checked by the volume octree's own checks
// (sylva/octree/validate.hpp), which read only the node records both formats share.
#ifndef SYLVA_OCTREE_ELEMENTS_VALIDATE_HPP
#define SYLVA_OCTREE_ELEMENTS_VALIDATE_HPP

#include <bit>
#include <cstdint>
#include <span>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/octree/validate.hpp"
#include "sylva/shared/octree_elem_iter.h"

namespace sylva::octree {

namespace detail {

[[noreturn]] inline void invalid_elements(const std::string& what) { throw Error("octree::validate_elements: " + what); }

/// Header words one by one, each failure with its own message, then the shared reader.
inline shared::SylvaOctHeader validate_elements_header(std::span<const std::uint32_t> w, std::size_t element_count) {
    if (w.size() < SYLVA_OCT_HEADER_WORDS) invalid_elements(std::to_string(w.size()) + " words, shorter than the 20-word header");
    if (w.size() > 0xFFFFFFFFu) invalid_elements("more than 2^32 - 1 words");
    if (w[0] != SYLVA_OCT_MAGIC) invalid_elements("bad magic (not an octree encoding)");
    if (w[1] != SYLVA_OCT_VERSION) invalid_elements("unsupported version " + std::to_string(w[1]));
    if ((w[5] >> 24) != SYLVA_OCTE_FORMAT_ELEMENTS)
        invalid_elements("format " + std::to_string(w[5] >> 24) + " is not 1 (an element octree)");
    if (w[9] != w.size())
        invalid_elements("the header says " + std::to_string(w[9]) + " words, the buffer holds " + std::to_string(w.size()));
    if (w[7] != element_count)
        invalid_elements("built over " + std::to_string(w[7]) + " elements, " + std::to_string(element_count) + " given");
    std::size_t body = w.size() - SYLVA_OCT_HEADER_WORDS;
    if (w[6] == 0u || std::size_t{w[6]} * SYLVA_OCT_NODE_WORDS > body || body - std::size_t{w[6]} * SYLVA_OCT_NODE_WORDS != w[8])
        invalid_elements(std::to_string(w[6]) + " nodes and " + std::to_string(w[8]) + " reference words do not fill the " +
                         std::to_string(body) + " words after the header");
    shared::Words buf{w.data(), w.size()};
    shared::SylvaOctHeader h = shared::sylva_octe_read_header(buf, static_cast<std::uint32_t>(w.size()));
    if (h.valid == 0u)
        invalid_elements("extents, cell size (4), border (1), levels, spacing, 1 / spacing or origin out of range");
    return h;
}

/// One record: reserved words and bits, level, coordinates, root, child fields, and its
/// reference list (in the reference words, count >= 1, each reference below the element
/// count, ascending).
inline void validate_element_record(std::span<const std::uint32_t> w, const shared::SylvaOctHeader& h, std::size_t n) {
    using namespace sylva::shared;
    const std::uint32_t* r = &w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n];
    std::string node = "node " + std::to_string(n);
    if ((r[1] & ~0x31FFFu) != 0u || (r[3] >> 16) != 0u || r[10] != 0u || r[11] != 0u || r[13] != 0u || r[14] != 0u ||
        r[15] != 0u)
        invalid_elements(node + " has reserved bits set (cut bits, densities or the out-of-core words)");
    std::uint32_t level = sylva_oct_level(r[1]), mask = sylva_oct_child_mask(r[1]);
    if (level >= h.levels) invalid_elements(node + " is at level " + std::to_string(level) + " of " + std::to_string(h.levels));
    glm::u32vec3 c(r[2] & 0xFFFFu, r[2] >> 16, r[3]);
    std::uint32_t width = sylva_oct_width(h, level);
    for (int a = 0; a < 3; ++a)
        if (std::uint64_t{c[a]} * width >= h.dims[a]) invalid_elements(node + " starts outside the lattice along axis " + std::to_string(a));
    if (n == 0 && (level != 0u || c != glm::u32vec3(0u))) invalid_elements("node 0 is not the root");
    if ((mask == 0u) != (r[0] == SYLVA_OCT_NONE)) invalid_elements(node + ": its first child and child mask disagree");
    if (mask != 0u && (level + 1 >= h.levels || std::uint64_t{r[0]} + std::popcount(mask) > h.node_count))
        invalid_elements(node + "'s children are out of range");
    std::uint32_t state = sylva_oct_brick_state(r[1]), at = r[12];
    if (at == SYLVA_OCT_NONE) {
        if (state != SYLVA_OCT_BRICK_ABSENT) invalid_elements(node + " has no reference list but its state says one is resident");
        return;
    }
    std::size_t begin = SYLVA_OCT_HEADER_WORDS + std::size_t{SYLVA_OCT_NODE_WORDS} * h.node_count;
    if (mask != 0u || state != SYLVA_OCT_BRICK_RESIDENT) invalid_elements(node + " names a reference list but is not a resident leaf");
    if (at < begin || at >= w.size() || w[at] == 0u || w[at] > w.size() - at - 1)
        invalid_elements(node + "'s reference list at word " + std::to_string(at) + " is outside the reference words or empty");
    for (std::uint32_t k = 0; k < w[at]; ++k) {
        std::uint32_t e = w[at + 1 + k];
        if (e >= h.brick_count)
            invalid_elements(node + " references element " + std::to_string(e) + " of " + std::to_string(h.brick_count));
        if (k > 0 && e <= w[at + k]) invalid_elements(node + "'s references are not ascending");
    }
}

}  // namespace detail

/// Checks an element-octree index (`words`) built over `element_count` elements: every header
/// field; per node the reserved bits, level, coordinates, child fields and its reference list
/// (inside the reference words, non-empty, ascending references below the element count);
/// children one level down at the right coordinates, each node but the root the child of
/// exactly one node; every neighbour pointer equal to the node whose box touches that face.
/// Throws sylva::Error naming the first problem.
inline void validate_elements(std::span<const std::uint32_t> words, std::size_t element_count) {
    shared::SylvaOctHeader h = detail::validate_elements_header(words, element_count);
    for (std::size_t n = 0; n < h.node_count; ++n) detail::validate_element_record(words, h, n);
    try {
        detail::validate_children(words, h);
        detail::validate_neighbours(words, h);
    } catch (const Error& e) {
        std::string m = e.what();
        std::string prefix = "octree::validate: ";
        detail::invalid_elements(m.rfind(prefix, 0) == 0 ? m.substr(prefix.size()) : m);
    }
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_ELEMENTS_VALIDATE_HPP
