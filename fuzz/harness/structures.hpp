// fuzz/harness/structures.hpp -- harnesses of the encoded structures (the bricked octrees in
// octree.hpp): each input is an
// encoding (32-bit little-endian words, sometimes after a word saying how it splits), given to
// the structure's validate() and then walked, whether accepted or not, by the shared iterator
// for a handful of rays. The promises checked (anything else is a finding):
//  - validate() either accepts or throws sylva::Error; it never reads outside the buffer;
//  - the iterator over ANY words ends (DONE or ERROR) and yields only nodes/leaves that exist;
//  - over words validate() accepted, every walk ends DONE (never ERROR) and yields what the
//    encoding promises (leaf ranges inside the element count, references below it).
// The seeds are encodings of small built trees (fuzz/make_corpus.cpp), so mutations start
// from valid encodings and reach the deep checks.
#ifndef SYLVA_FUZZ_HARNESS_STRUCTURES_HPP
#define SYLVA_FUZZ_HARNESS_STRUCTURES_HPP

#include <algorithm>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/validate.hpp>
#include <sylva/core/error.hpp>
#include <sylva/ikd/packet.hpp>
#include <sylva/ikd/validate.hpp>
#include <sylva/kdtree/query.hpp>
#include <sylva/kdtree/validate.hpp>
#include <sylva/octree/elements_validate.hpp>
#include <sylva/shared/bih_iter.h>
#include <sylva/shared/ikd_iter.h>
#include <sylva/shared/kd_iter.h>
#include <sylva/shared/octree_elem_iter.h>
#include <sylva/shared/octree_iter.h>
#include <sylva/shared/voxel.h>

#include "common.hpp"

namespace sylva_fuzz {

/// `words` = [N, the first part's N words..., the second part's words...] split in two (N is
/// clamped to what is there).
struct TwoParts {
    std::vector<std::uint32_t> first;
    std::vector<std::uint32_t> second;
};
inline TwoParts two_parts(const std::vector<std::uint32_t>& w) {
    if (w.empty()) return {};
    std::size_t n = std::min<std::size_t>(w[0], w.size() - 1);
    return {std::vector<std::uint32_t>(w.begin() + 1, w.begin() + 1 + static_cast<std::ptrdiff_t>(n)),
            std::vector<std::uint32_t>(w.begin() + 1 + static_cast<std::ptrdiff_t>(n), w.end())};
}

/// True when `f` throws sylva::Error (any other exception escapes: a finding).
template <class F>
bool refuses(F&& f) {
    try {
        f();
        return false;
    } catch (const sylva::Error&) {
        return true;
    }
}

/// Walks the BIH `words` for each ray; `element_count` > 0 checks range payloads against it.
inline void walk_bih(const std::vector<std::uint32_t>& words, bool valid, std::uint64_t element_count) {
    using namespace sylva::shared;
    Words buf{words.data(), words.size()};
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
    std::uint32_t kind = (h.flags >> 8) & 255u;
    for (const sylva::Ray& r : rays_over(h.root_lo, h.root_hi)) {
        sylva::bih::LeafIterator it(words, r);
        std::size_t n = 0;
        while (auto hit = it.next()) {
            SYLVA_FUZZ_CHECK(hit->node < h.node_count, "a leaf outside the nodes");
            if (valid) SYLVA_FUZZ_CHECK(++n <= h.node_count, "more leaves than nodes from an accepted encoding");
            if (valid && kind == SYLVA_PAYLOAD_RANGE && element_count) {
                auto [first, count] = sylva::bih::decode_range(hit->payload);
                SYLVA_FUZZ_CHECK(std::uint64_t{first} + count <= element_count, "a leaf range past the elements");
            }
            if (kind == SYLVA_PAYLOAD_VOXEL) {
                SylvaVoxel v = sylva_voxel_unpack(uvec2(std::uint32_t(hit->payload), std::uint32_t(hit->payload >> 32)));
                (void)v;
            }
        }
        SYLVA_FUZZ_CHECK(it.status() != SYLVA_ITER_RUNNING, "a walk stopped while running");
        if (valid) SYLVA_FUZZ_CHECK(it.status() == SYLVA_ITER_DONE, "an accepted BIH walked into an error");
    }
}

/// Input: [element count, BIH words...]. bih::validate, then the walk.
inline int fuzz_bih(const std::uint8_t* data, std::size_t size) {
    std::vector<std::uint32_t> w = words_of(data, size);
    if (w.empty()) return 0;
    std::uint64_t elements = w[0];
    std::vector<std::uint32_t> words(w.begin() + 1, w.end());
    bool valid = !refuses([&] { sylva::bih::validate(words, elements); });
    walk_bih(words, valid, elements);
    return 0;
}

/// Input: the words of an encoded LoD (a BIH with voxel payloads, bih/lod.hpp). validate, the
/// iso-culling node ranges of an accepted voxel encoding, then the walk.
inline int fuzz_lod(const std::uint8_t* data, std::size_t size) {
    std::vector<std::uint32_t> words = words_of(data, size);
    bool valid = !refuses([&] { sylva::bih::validate(words); });
    if (valid) {
        std::vector<std::uint32_t> ranges;
        bool refused = refuses([&] { ranges = sylva::bih::encode_node_ranges(words, sylva::vec3(1.0f, 1.0f, 1.4f)); });
        sylva::shared::Words buf{words.data(), words.size()};
        auto h = sylva::shared::sylva_bih_read_header(buf, static_cast<std::uint32_t>(words.size()));
        bool voxels = ((h.flags >> 8) & 255u) == SYLVA_PAYLOAD_VOXEL;
        SYLVA_FUZZ_CHECK(refused != voxels, "node ranges refused for a valid voxel encoding, or made for another kind");
        // (min may exceed max: a mutated plane can give a leaf an inverted, empty box, which no
        // ray enters, and whose range is then empty too.)
        if (voxels) SYLVA_FUZZ_CHECK(ranges.size() == h.node_count, "a node range per node");
    }
    walk_bih(words, valid, 0);
    return 0;
}

/// Input: the words of an encoded kd-tree. kdtree::validate, then the walk.
inline int fuzz_kd(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::shared;
    std::vector<std::uint32_t> words = words_of(data, size);
    bool valid = !refuses([&] { sylva::kdtree::validate(words); });
    SylvaKdHeader h = sylva_kd_read_header(Words{words.data(), words.size()},
                                           static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
    vec3 hi = h.origin + vec3(h.dims) * h.spacing;
    for (const sylva::Ray& r : rays_over(h.origin, hi)) {
        sylva::kdtree::LeafIterator it(words, r);
        std::size_t n = 0;
        while (auto hit = it.next()) {
            SYLVA_FUZZ_CHECK(hit->leaf < h.leaf_count, "a leaf index past the leaf count");
            SYLVA_FUZZ_CHECK(++n <= h.node_count, "more leaves than nodes");
        }
        SYLVA_FUZZ_CHECK(it.steps() <= std::max<std::uint32_t>(h.node_count, 1u), "more steps than nodes");
        SYLVA_FUZZ_CHECK(it.status() != SYLVA_ITER_RUNNING, "a walk stopped while running");
        if (valid) SYLVA_FUZZ_CHECK(it.status() == SYLVA_ITER_DONE, "an accepted kd-tree walked into an error");
    }
    return 0;
}

/// Input: [index word count N, N index words, grid words...] of an implicit kd-tree.
/// ikd::validate(index, grid size), then candidate cells of two isovalues along each ray.
inline int fuzz_ikd(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::shared;
    TwoParts p = two_parts(words_of(data, size));
    const std::vector<std::uint32_t>& words = p.first;
    const std::vector<std::uint32_t>& grid = p.second;
    bool valid = !refuses([&] { sylva::ikd::validate(words, grid.size()); });
    Words w{words.data(), words.size()}, g{grid.data(), grid.size()};
    uint wc = static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    uint gc = static_cast<uint>(std::min<std::size_t>(grid.size(), 0xFFFFFFFFu));
    SylvaIkdHeader h = sylva_ikd_read_header(w, wc, gc);
    vec3 hi = h.origin + vec3(h.cells) * h.spacing;
    const sylva::vec4 isos(0.35f, 0.6f, 0.0f, 0.0f);
    std::uint64_t cells = std::uint64_t{h.cells.x} * h.cells.y * h.cells.z;
    for (const sylva::Ray& r : rays_over(h.origin, hi)) {
        SylvaIkdIter it;
        sylva_ikd_init(it, w, wc, gc, r.origin, r.direction, 0.0f, 1e30f, isos, 2u);
        uvec3 cell;
        float t0, t1;
        std::uint64_t n = 0;
        std::vector<std::uint32_t> single;  // cell x, y, z, t0 bits, t1 bits
        while (sylva_ikd_next(it, w, g, cell, t0, t1)) {
            SYLVA_FUZZ_CHECK(cell.x < h.cells.x && cell.y < h.cells.y && cell.z < h.cells.z, "a cell outside the grid");
            SYLVA_FUZZ_CHECK(++n <= cells, "more candidate cells than cells");
            single.insert(single.end(), {cell.x, cell.y, cell.z, std::bit_cast<std::uint32_t>(t0), std::bit_cast<std::uint32_t>(t1)});
        }
        SYLVA_FUZZ_CHECK(it.status != SYLVA_ITER_RUNNING, "a walk stopped while running");
        if (valid) SYLVA_FUZZ_CHECK(it.status == SYLVA_ITER_DONE, "an accepted implicit kd-tree walked into an error");
        // The same ray as lane 0 of a packet of 8 (the other lanes parallel to it, shifted): its
        // cells and intervals are the single ray's, every lane's cells inside the grid.
        sylva::ikd::RayPacket8 pk;
        for (int k = 0; k < 8; ++k) {
            pk.origin[k] = r.origin + float(k) * 0.37f * vec3(1.0f, 0.5f, 0.25f);
            pk.direction[k] = r.direction;
            pk.t_min[k] = 0.0f;
            pk.t_max[k] = 1e30f;
        }
        pk.active = 0xFFu;
        sylva::ikd::PacketIter8 packet(words, grid, pk, isos, 2u);
        sylva::ikd::PacketCell8 c;
        std::vector<std::uint32_t> lane0;
        std::uint64_t visits = 0;
        while (packet.next(c)) {
            SYLVA_FUZZ_CHECK(c.cell.x < h.cells.x && c.cell.y < h.cells.y && c.cell.z < h.cells.z, "a packet cell outside the grid");
            SYLVA_FUZZ_CHECK(++visits <= 8 * cells, "more packet cells than cells of all lanes");
            if (c.mask & 1u)
                lane0.insert(lane0.end(), {c.cell.x, c.cell.y, c.cell.z, std::bit_cast<std::uint32_t>(c.t0[0]),
                                           std::bit_cast<std::uint32_t>(c.t1[0])});
        }
        SYLVA_FUZZ_CHECK(packet.status() == it.status, "a packet walk ended otherwise than the single ray's");
        SYLVA_FUZZ_CHECK(lane0 == single, "a packet lane's cells differ from its single ray's");
    }
    return 0;
}

/// Input: [element count, element octree words...]. octree::validate_elements, then the walk
/// and every reference of every leaf.
inline int fuzz_octree_elements(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::shared;
    std::vector<std::uint32_t> w = words_of(data, size);
    if (w.empty()) return 0;
    std::uint32_t elements = w[0];
    std::vector<std::uint32_t> words(w.begin() + 1, w.end());
    bool valid = !refuses([&] { sylva::octree::validate_elements(words, elements); });
    Words sw{words.data(), words.size()};
    uint wc = static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    SylvaOctHeader h = sylva_octe_read_header(sw, wc);
    vec3 hi = h.origin + vec3(h.dims) * h.spacing;
    for (const sylva::Ray& r : rays_over(h.origin, hi)) {
        SylvaOctElemIter it;
        sylva_octe_init(it, sw, wc, r.origin, r.direction, 0.0f, 1e30f);
        std::uint32_t node, first, count;
        std::uint64_t leaves = 0;
        float t0, t1;
        while (sylva_octe_next(it, sw, node, t0, t1, first, count)) {
            SYLVA_FUZZ_CHECK(std::uint64_t{first} + count <= words.size(), "a reference list past the buffer");
            SYLVA_FUZZ_CHECK(++leaves <= it.walk.step_limit, "more leaves than the step limit");
            for (std::uint32_t k = 0; k < count; ++k) {
                std::uint32_t e = sylva_octe_element(it, sw, first + k);
                if (valid) SYLVA_FUZZ_CHECK(e < elements, "an accepted encoding references a missing element");
            }
        }
        SYLVA_FUZZ_CHECK(it.walk.status != SYLVA_ITER_RUNNING, "a walk stopped while running");
        if (valid) SYLVA_FUZZ_CHECK(it.walk.status == SYLVA_ITER_DONE, "an accepted element octree walked into an error");
    }
    return 0;
}

}  // namespace sylva_fuzz

#endif  // SYLVA_FUZZ_HARNESS_STRUCTURES_HPP
