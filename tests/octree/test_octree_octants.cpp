// Octant masks (sylva/octree/octants.hpp, sylva_oct_dvr_ray_masked): the octant ranges against
// brute force over the voxels trilinear sampling in each octant can read; the masked DVR equals
// the unmasked one (and the marcher) bit for bit over volumes, brick sizes, cuts, shading and
// views along the mid-planes, with fewer samples where octants are empty.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/procedural.hpp>

#include "frames.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

/// Transparent below `lo`, a ramp of opacity above.
std::vector<std::uint32_t> ramp_tf(float lo) {
    std::vector<std::uint32_t> tf(256);
    for (std::size_t i = 0; i < tf.size(); ++i) {
        float d = float(i) / 255.0f;
        tf[i] = rgba8(0.3f + 0.7f * d, 0.8f - 0.4f * d, 0.5f, d <= lo ? 0.0f : 0.35f * (d - lo) / (1.0f - lo));
    }
    return tf;
}

/// Brute force: the min/max of coarse voxels [c B + o B/2 - 1, c B + o B/2 + B/2] (clamped to
/// the level's extent) of node n, per axis, from the LoD pyramid the builder used.
std::pair<float, float> reference_octant(const octree::Tree& t, const std::vector<octree::detail::LodLevel>& lod,
                                         const octree::Node& node, std::uint32_t o) {
    const auto& src = lod[t.levels - 1u - node.level];
    glm::ivec3 lo, hi;
    for (int k = 0; k < 3; ++k) {
        int start = int(node.coord[k] * t.brick_size + ((o >> k) & 1u) * t.brick_size / 2u);
        lo[k] = std::clamp(start - 1, 0, int(src.dims[k]) - 1);
        hi[k] = std::clamp(start + int(t.brick_size / 2u), 0, int(src.dims[k]) - 1);
    }
    float a = std::numeric_limits<float>::infinity(), b = -a;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                float v = src.at(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
                a = std::min(a, v);
                b = std::max(b, v);
            }
    return {a, b};
}

}  // namespace

TEST_CASE("octant ranges equal brute force over the voxels each octant's samples read", "[octree][octants]") {
    ThreadPool pool(2);
    for (octree::Config cfg : {octree::Config{8, 1}, octree::Config{16, 2}, octree::Config{4, 2}}) {
        volume::DensityGrid g = blobs({37, 22, 51}, 31);
        octree::Tree t = octree::build(g, pool, cfg);
        std::vector<std::uint32_t> words = octree::encode(t);
        octree::OctantRanges r = octree::octant_ranges(words, t.bricks, pool);
        REQUIRE(r.nodes() == t.nodes.size());
        auto lod = octree::detail::lod_pyramid(g, t.levels, pool);
        std::size_t checked = 0;
        for (std::size_t n = 0; n < t.nodes.size(); ++n)
            for (std::uint32_t o = 0; o < 8; ++o) {
                auto [a, b] = reference_octant(t, lod, t.nodes[n], o);
                INFO("B " << cfg.brick_size << " node " << n << " octant " << o);
                REQUIRE(r.values[16 * n + 2 * o] == a);
                REQUIRE(r.values[16 * n + 2 * o + 1] == b);
                ++checked;
            }
        CHECK(checked == 8 * t.nodes.size());
    }
}

TEST_CASE("octant-masked DVR renders the unmasked image bit for bit with fewer samples", "[octree][octants][dvr]") {
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        octree::Config cfg;
        vec3 view;
    };
    std::vector<Case> cases;
    cases.push_back({blobs({64, 64, 64}, 24), {16, 2}, {0.3f, 0.5f, 1.0f}});
    cases.push_back({blobs({33, 17, 70}, 21), {16, 2}, {0.4f, 0.3f, 1.0f}});
    cases.push_back({blobs({45, 40, 38}, 22, vec3(1.0f, 0.5f, 2.0f)), {32, 2}, {-0.7f, 0.2f, -0.5f}});
    cases.push_back({blobs({70, 9, 20}, 23), {8, 1}, {1.0f, 0.0f, 0.0f}});  // rays in mid-planes and leaf planes
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {16, 2}, {0.0f, 0.0f, 1.0f}});
    std::uint64_t masked_total = 0, plain_total = 0;
    for (const Case& c : cases) {
        octree::Tree t = octree::build(c.grid, pool, c.cfg);
        std::vector<std::uint32_t> words = octree::encode(t);
        octree::OctantRanges ranges = octree::octant_ranges(words, t.bricks, pool);
        // A constant border the TF shows (1: faces blend up to (v + 1) / 2) must not be skipped,
        // neither by masks of the voxels alone (the renderer samples face octants then) nor by
        // masks made for that border (their face octants' ranges include it).
        for (GridBorder border : {GridBorder::clamp(), GridBorder::constant(1.0f)}) {
        GridWords gw = GridWords::from(c.grid, border);
        for (float lo : {0.3f, 0.6f})
            for (bool shading : {false, true})
                for (std::uint32_t max_level : {0xFFFFFFFFu, t.levels > 1 ? t.levels - 2u : 0u}) {
                    VolumeRenderParams p;
                    p.camera = Camera::framing(c.grid.world_box(), c.view, 35.0f).frame(56, 56);
                    p.width = p.height = 56;
                    p.tf = ramp_tf(lo);
                    p.shading = shading;
                    std::vector<std::uint32_t> masks = octree::octant_masks(ranges, tf_opacity_prefix(p.tf));
                    Frame plain = render_octree_dvr_cpu(OctreeView{words, t.bricks, max_level, {}, {}, border}, p, pool);
                    Frame masked = render_octree_dvr_cpu(OctreeView{words, t.bricks, max_level, {}, masks, border}, p, pool);
                    INFO("B " << c.cfg.brick_size << " tf lo " << lo << " shading " << shading << " max level " << max_level
                              << " border " << border.value);
                    CHECK(differing(plain, masked) == 0);
                    if (border.mode == BorderMode::Constant) {
                        std::vector<std::uint32_t> bmasks = octree::octant_masks(ranges, tf_opacity_prefix(p.tf), border.value);
                        Frame bmasked = render_octree_dvr_cpu(OctreeView{words, t.bricks, max_level, {}, bmasks, border}, p, pool);
                        CHECK(differing(plain, bmasked) == 0);
                        for (std::size_t i = 0; i < plain.steps.size(); ++i) REQUIRE(bmasked.steps[i] <= plain.steps[i]);
                        for (std::size_t n = 0; n < masks.size(); ++n) {
                            REQUIRE((bmasks[n] & SYLVA_OCT_OCTMASK_BORDER) != 0u);
                            REQUIRE((bmasks[n] & masks[n]) == masks[n]);  // the border only adds bits
                        }
                    }
                    // The marcher's image needs the full cut, and border 2 when shaded (octree_dvr.h).
                    if (max_level == 0xFFFFFFFFu && (c.cfg.border == 2 || !shading))
                        CHECK(differing(render_dvr_cpu(gw, p, pool), masked) == 0);
                    for (std::size_t i = 0; i < plain.steps.size(); ++i) REQUIRE(masked.steps[i] <= plain.steps[i]);
                    masked_total += total_samples(masked);
                    plain_total += total_samples(plain);
                }
        }
    }
    INFO("samples: masked " << masked_total << ", plain " << plain_total);
    CHECK(masked_total < plain_total * 9 / 10);  // the octants do skip something
}

TEST_CASE("octant masks for a constant border the TF leaves transparent skip as much as the voxels' own", "[octree][octants]") {
    // A border of 0 under a TF transparent below 0.3: widening a face octant's range to 0 adds
    // only transparent densities, so the masks equal the voxels' masks (plus bit 8), and the
    // renderer, trusting them, takes fewer samples than with face octants forced on.
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({64, 64, 64}, 24);
    octree::Tree t = octree::build(g, pool, {16, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::OctantRanges ranges = octree::octant_ranges(words, t.bricks, pool);
    VolumeRenderParams p;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.5f, 1.0f}, 35.0f).frame(48, 48);
    p.width = p.height = 48;
    p.tf = ramp_tf(0.55f);
    std::vector<std::uint32_t> voxel_masks = octree::octant_masks(ranges, tf_opacity_prefix(p.tf));
    std::vector<std::uint32_t> zero_masks = octree::octant_masks(ranges, tf_opacity_prefix(p.tf), 0.0f);
    for (std::size_t n = 0; n < voxel_masks.size(); ++n) REQUIRE(zero_masks[n] == (voxel_masks[n] | SYLVA_OCT_OCTMASK_BORDER));
    Frame forced = render_octree_dvr_cpu(OctreeView{words, t.bricks, 0xFFFFFFFFu, {}, voxel_masks}, p, pool);
    Frame trusted = render_octree_dvr_cpu(OctreeView{words, t.bricks, 0xFFFFFFFFu, {}, zero_masks}, p, pool);
    CHECK(differing(forced, trusted) == 0);
    CHECK(differing(render_dvr_cpu(GridWords::from(g), p, pool), trusted) == 0);
    INFO("samples: face octants forced " << total_samples(forced) << ", masks for the border " << total_samples(trusted));
    CHECK(total_samples(trusted) < total_samples(forced));
    CHECK_THROWS_WITH(octree::octant_masks(ranges, tf_opacity_prefix(p.tf), NAN), Catch::Contains("not finite"));
}

TEST_CASE("octant masks: a TF with no opacity clears every bit, an opaque one sets them; wrong sizes are refused",
          "[octree][octants][errors]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({20, 20, 20}, 5);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::OctantRanges r = octree::octant_ranges(words, t.bricks, pool);
    std::vector<std::uint32_t> clear(256, 0u), opaque(256, 0xFF000000u);
    for (std::uint32_t m : octree::octant_masks(r, tf_opacity_prefix(clear))) CHECK(m == 0u);
    for (std::uint32_t m : octree::octant_masks(r, tf_opacity_prefix(opaque))) CHECK(m == 255u);
    VolumeRenderParams p;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.2f, 1.0f}, 35.0f).frame(8, 8);
    p.width = p.height = 8;
    p.tf = opaque;
    std::vector<std::uint32_t> short_masks(3, 255u);
    CHECK_THROWS_WITH(render_octree_dvr_cpu(OctreeView{words, t.bricks, 0xFFFFFFFFu, {}, short_masks}, p, pool),
                      Catch::Contains("3 octant masks for"));
    std::vector<std::uint32_t> bad = words;
    bad[0] ^= 1u;
    CHECK_THROWS_WITH(octree::octant_ranges(bad, t.bricks, pool), Catch::Contains("not a valid encoded octree"));
    CHECK_THROWS_AS(octree::octant_masks(r, {}), Error);
}
