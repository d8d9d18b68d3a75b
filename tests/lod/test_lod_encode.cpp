// The LoD's 8-byte-node encoding read back through the shared decoder and iterator, and the
// node-range words for iso-value culling.
#include <catch2/catch.hpp>

#include <functional>
#include <random>

#include <sylva/bih/lod.hpp>
#include <sylva/shared/bih_iter.h>
#include <sylva/shared/voxel.h>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;
using namespace sylva::shared;

namespace {

struct Encoded {
    std::vector<VoxelCuboid> cuboids;
    bih::FullBih full;
    bih::Lod lod;
    std::vector<std::uint32_t> words;
};

Encoded make_encoded(bih::EmptyChildren variant, std::uint32_t chunk_depth) {
    volume::DensityGrid g = lodtest::synthetic_grid({30, 26, 18}, vec3(1.0f, 1.0f, 1.4f), 31u);
    Encoded e;
    e.cuboids = volume::voxel_cuboids(g, 0.1f);
    bih::Config cfg;
    cfg.empty_children = variant;
    e.full = bih::build_full(e.cuboids, cfg);
    bih::LodConfig lc;
    lc.chunk_depth = chunk_depth;
    e.lod = bih::extract_lod(e.full, lc);
    e.words = bih::encode_lod(e.lod, lc);
    return e;
}

/// One world-space quantisation step of the 16-bit planes per axis.
vec3 plane_step(const Aabb& root) { return root.extent() / 32768.0f; }

}  // namespace

TEST_CASE("the encoded LoD decodes to the LoD leaves through the shared iterator", "[lod][encode]") {
    auto variant = GENERATE(bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite);
    std::uint32_t chunk_depth = GENERATE(0u, 2u);
    Encoded e = make_encoded(variant, chunk_depth);
    Words buf{e.words.data(), e.words.size()};
    REQUIRE_NOTHROW(bih::validate(e.words));
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(e.words.size()));
    REQUIRE(h.valid == 1u);
    CHECK(h.node_count == e.lod.tree.nodes.size());
    CHECK(h.max_depth == e.lod.stats.max_depth);
    CHECK(((h.flags >> 2) & 15u) == chunk_depth);
    CHECK(((h.flags >> 8) & 255u) == SYLVA_PAYLOAD_VOXEL);
    CHECK(e.words.size() == SYLVA_BIH_HEADER_WORDS + 2 * e.lod.tree.nodes.size());  // 8 bytes a node

    // Aim one ray at the centre of every LoD leaf; the leaf of the encoding whose decoded box
    // holds that centre must carry this leaf's density and gradient.
    std::mt19937 rng(4);
    std::normal_distribution<float> nd(0.0f, 1.0f);
    vec3 step = plane_step(e.lod.tree.bounds);
    float diag = glm::length(e.lod.tree.bounds.extent());
    for (std::size_t i = 0; i < e.lod.leaves.size(); ++i) {
        const VoxelCuboid& want = e.lod.leaves[i];
        vec3 c = want.box.center();
        vec3 dir = glm::normalize(vec3(nd(rng), nd(rng), nd(rng)) + vec3(1e-3f));
        SylvaBihIter it;
        sylva_bih_init(it, buf, static_cast<uint>(e.words.size()), c - dir * (2.0f * diag), dir, 0.0f, 1e30f);
        uint leaf;
        float t0, t1;
        int found = 0;
        while (sylva_bih_next(it, buf, leaf, t0, t1)) {
            vec3 lo = sylva_bih_to_world(it.hdr, it.leaf_lo), hi = sylva_bih_to_world(it.hdr, it.leaf_hi);
            if (!Aabb{lo, hi}.contains(Aabb{c, c})) continue;
            ++found;
            INFO("LoD leaf " << i << " at encoded node " << leaf);
            CHECK(glm::all(glm::lessThanEqual(glm::abs(lo - want.box.lo), step * 1.01f)));
            CHECK(glm::all(glm::lessThanEqual(glm::abs(hi - want.box.hi), step * 1.01f)));
            SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(buf, it.hdr, leaf));
            CHECK(v.density == Approx(want.density).margin(0.5f / 16383.0f + 1e-6f));
            for (int a = 0; a < 3; ++a)
                CHECK(v.gradient[a] == Approx(glm::clamp(want.gradient[a], -1.0f, 1.0f)).margin(0.5f / 32767.0f + 1e-6f));
            vec3 x = c + 0.3f * (hi - lo) * vec3(0.5f, -0.7f, 0.2f);  // a point inside the leaf
            float got = sylva_voxel_density_at(v, x, (lo + hi) * 0.5f, e.lod.voxel_size);
            float ref = want.density + glm::dot(want.gradient, (x - c) / e.lod.voxel_size);
            CHECK(got == Approx(ref).margin(2e-3f));
        }
        REQUIRE(it.status == SYLVA_ITER_DONE);
        REQUIRE(found == 1);
    }
}

TEST_CASE("node-range words bound the reconstructed density of every leaf under them", "[lod][encode][ranges]") {
    auto variant = GENERATE(bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite);
    Encoded e = make_encoded(variant, 2u);
    std::vector<std::uint32_t> ranges = bih::encode_node_ranges(e.words, e.lod.voxel_size);
    REQUIRE(ranges.size() == e.lod.tree.nodes.size());
    CHECK(bih::encode_node_ranges(e.lod, bih::LodConfig{}) == ranges);
    Words buf{e.words.data(), e.words.size()};
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(e.words.size()));
    auto lo16 = [&](std::uint32_t n) { return float(ranges[n] & 0xFFFFu) / 65535.0f; };
    auto hi16 = [&](std::uint32_t n) { return float(ranges[n] >> 16) / 65535.0f; };

    // Independent walk of the encoding: collect the leaves under each node with their decoded
    // world boxes, then evaluate the reconstruction at the corners (the extremes of a linear
    // function over a box) and the centre of every leaf.
    struct LeafBox { std::uint32_t node; vec3 lo, hi; };
    std::size_t checked = 0;
    std::function<std::vector<LeafBox>(std::uint32_t, vec3, vec3)> walk = [&](std::uint32_t n, vec3 lo, vec3 hi) {
        uint meta = sylva_bih_meta(buf, h, n);
        if ((meta & 3u) == SYLVA_BIH_LEAF) return std::vector<LeafBox>{{n, lo, hi}};
        uint axis = meta & 3u;
        vec2 p = sylva_bih_planes(buf, h, n);
        std::vector<LeafBox> under;
        auto take = [&](std::uint32_t kid, vec3 klo, vec3 khi) {
            std::vector<LeafBox> sub = walk(kid, klo, khi);
            under.insert(under.end(), sub.begin(), sub.end());
        };
        if (meta & 4u) {
            take(meta >> 3u, sylva_with(lo, axis, p.x), sylva_with(hi, axis, p.y));  // tree chunks: index = child
        } else {
            uvec2 kids = sylva_bih_children(h, n, meta, p);
            if (kids.x != SYLVA_NO_NODE) take(kids.x, lo, sylva_with(hi, axis, p.x));
            if (kids.y != SYLVA_NO_NODE) take(kids.y, sylva_with(lo, axis, p.y), hi);
        }
        for (const LeafBox& l : under) {
            vec3 wlo = sylva_bih_to_world(h, l.lo), whi = sylva_bih_to_world(h, l.hi);
            SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(buf, h, l.node));
            for (int c = 0; c < 9; ++c) {
                vec3 x = c == 8 ? (wlo + whi) * 0.5f
                                : vec3((c & 1) ? whi.x : wlo.x, (c & 2) ? whi.y : wlo.y, (c & 4) ? whi.z : wlo.z);
                float d = glm::clamp(sylva_voxel_density_at(v, x, (wlo + whi) * 0.5f, e.lod.voxel_size), 0.0f, 1.0f);
                for (std::uint32_t m : {n, l.node})
                    if (!(lo16(m) <= d && hi16(m) >= d))  // REQUIRE only on failure: ~10^5 checks
                        FAIL("node " << m << " range [" << lo16(m) << ", " << hi16(m) << "] misses density " << d
                                     << " of leaf " << l.node);
                ++checked;
            }
        }
        return under;
    };
    std::vector<LeafBox> all = walk(0u, vec3(0.0f), vec3(1.0f));
    CHECK(all.size() == e.lod.leaves.size());
    CHECK(checked > 0);

    // leaf ranges are tight: within a few unorm16 steps of the exact corner extremes
    for (const LeafBox& l : all) {
        vec3 wlo = sylva_bih_to_world(h, l.lo), whi = sylva_bih_to_world(h, l.hi);
        SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(buf, h, l.node));
        float mn = 1.0f, mx = 0.0f;
        for (int c = 0; c < 8; ++c) {
            vec3 x((c & 1) ? whi.x : wlo.x, (c & 2) ? whi.y : wlo.y, (c & 4) ? whi.z : wlo.z);
            float d = glm::clamp(sylva_voxel_density_at(v, x, (wlo + whi) * 0.5f, e.lod.voxel_size), 0.0f, 1.0f);
            mn = std::min(mn, d);
            mx = std::max(mx, d);
        }
        CHECK(lo16(l.node) >= mn - 3.0f / 65535.0f);
        CHECK(hi16(l.node) <= mx + 3.0f / 65535.0f);
    }
}

TEST_CASE("node ranges let a renderer cull an iso-value: the root range spans the data", "[lod][ranges]") {
    Encoded e = make_encoded(bih::EmptyChildren::TrimBoth, 2u);
    std::vector<std::uint32_t> ranges = bih::encode_node_ranges(e.lod);
    float lo = float(ranges[0] & 0xFFFFu) / 65535.0f, hi = float(ranges[0] >> 16) / 65535.0f;
    // the root holds the smallest and the largest reconstructed value of the whole LoD
    float dmin = 1.0f, dmax = 0.0f;
    for (const VoxelCuboid& c : e.lod.leaves) {
        dmin = std::min(dmin, c.density);
        dmax = std::max(dmax, c.density);
    }
    CHECK(lo <= dmin);
    CHECK(hi >= dmax);
    CHECK(hi <= 1.0f);
    CHECK(lo >= 0.0f);
    CHECK(dmax >= 0.9f * e.full.stats[0].max_density);  // the blob peak survives the LoD
}
