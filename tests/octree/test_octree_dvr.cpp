// DVR over the bricked octree (sylva/shared/octree_dvr.h): with the full-resolution cut the
// image equals the reference marcher's (sylva/shared/dvr.h) over the same grid bit for bit,
// shaded or not, over odd extents and both brick sizes; empty leaves are skipped without
// changing the image; coarser cuts converge towards it.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/octree/validate.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/procedural.hpp>

#include "frames.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

/// A TF transparent below `lo`, then a ramp of colour and opacity.
std::vector<std::uint32_t> ramp_tf(float lo, float alpha) {
    std::vector<std::uint32_t> tf(256);
    for (std::size_t i = 0; i < tf.size(); ++i) {
        float d = float(i) / 255.0f;
        tf[i] = rgba8(0.2f + 0.8f * d, 0.9f - 0.5f * d, 0.4f, d <= lo ? 0.0f : alpha * (d - lo) / (1.0f - lo));
    }
    return tf;
}

VolumeRenderParams params(const volume::DensityGrid& g, std::uint32_t size, vec3 view, bool shading, float lo) {
    VolumeRenderParams p;
    p.camera = Camera::framing(g.world_box(), view, 35.0f).frame(size, size);
    p.width = p.height = size;
    p.tf = ramp_tf(lo, 0.3f);
    p.shading = shading;
    return p;
}

/// Pixels whose RGBA bits differ.

double opacity_sum(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.w;
    return s;
}

}  // namespace

TEST_CASE("octree DVR: the full-resolution cut renders the marcher's image bit for bit", "[octree][dvr]") {
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        octree::Config cfg;
        vec3 view;
    };
    std::vector<Case> cases;
    cases.push_back({blobs({33, 17, 70}, 21), {16, 2}, {0.4f, 0.3f, 1.0f}});
    cases.push_back({blobs({45, 40, 38}, 22, vec3(1.0f, 0.5f, 2.0f)), {32, 2}, {-0.7f, 0.2f, -0.5f}});
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {16, 2}, {0.1f, 1.0f, 0.2f}});
    cases.push_back({blobs({70, 9, 20}, 23), {4, 2}, {1.0f, 0.0f, 0.0f}});  // axis-aligned view: rays in leaf planes
    std::size_t pixels = 0, lit = 0;
    for (const Case& c : cases) {
        octree::Tree t = octree::build(c.grid, pool, c.cfg);
        std::vector<std::uint32_t> words = octree::encode(t);
        // Clamped edges, the default constant 0, and a constant the TF makes visible (samples within
        // half a voxel of a face blend up to (v + 1) / 2 > 0.3): leaves on the volume's faces then
        // show it, so they must not be culled by the range of their voxels alone.
        for (GridBorder border : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(1.0f)}) {
            GridWords gw = GridWords::from(c.grid, border);
            for (bool shading : {false, true}) {
                VolumeRenderParams p = params(c.grid, 64, c.view, shading, 0.3f);
                Frame ref = render_dvr_cpu(gw, p, pool);
                Frame oct = render_octree_dvr_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = border}, p, pool);
                INFO(c.grid.dims.x << "x" << c.grid.dims.y << "x" << c.grid.dims.z << " B " << c.cfg.brick_size
                                   << " shading " << shading << " border " << int(border.mode) << " " << border.value);
                CHECK(differing(ref, oct) == 0);
                CHECK(max_diff(ref, oct) == 0.0);
                pixels += ref.rgba.size();
                for (const vec4& v : ref.rgba) lit += v.w > 0.05f ? 1 : 0;
            }
        }
    }
    CHECK(lit > pixels / 10);
}

TEST_CASE("octree DVR: a visible constant border shows on the faces of the volume", "[octree][dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({40, 36, 30}, 25);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = params(g, 48, {0.3f, 0.5f, 1.0f}, false, 0.3f);
    Frame clamped = render_octree_dvr_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = GridBorder::clamp()}, p, pool);
    Frame zero = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);  // default: constant 0
    Frame skin = render_octree_dvr_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = GridBorder::constant(1.0f)}, p,
                                       pool);
    // A visible constant border wraps the volume in a thin translucent skin: more opacity on
    // every ray that crosses the volume than with either other mode.
    CHECK(opacity_sum(skin) > opacity_sum(clamped) + 5.0);
    CHECK(opacity_sum(skin) > opacity_sum(zero) + 5.0);
    CHECK(differing(clamped, zero) > 0);
    OctreeView bad{.words = words, .bricks = t.bricks, .border = GridBorder::constant(std::nanf(""))};
    CHECK_THROWS_WITH(render_octree_dvr_cpu(bad, p, pool), Catch::Contains("border value is not finite"));
}

TEST_CASE("octree DVR: empty leaves are skipped (fewer samples), the image unchanged", "[octree][dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({64, 64, 64}, 24);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = params(g, 48, {0.3f, 0.5f, 1.0f}, true, 0.55f);
    Frame ref = render_dvr_cpu(GridWords::from(g), p, pool);  // both default to a constant 0 border
    Frame oct = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);
    CHECK(differing(ref, oct) == 0);
    std::uint64_t ref_steps = 0, oct_steps = 0;
    for (std::size_t i = 0; i < ref.steps.size(); ++i) {
        ref_steps += ref.steps[i];
        oct_steps += oct.steps[i];
    }
    INFO("marcher samples " << ref_steps << ", octree samples " << oct_steps);
    CHECK(oct_steps < ref_steps * 3 / 4);
    CHECK(opacity_sum(ref) > 10.0);
    // The prefix counts: entries with alpha > 0 before each entry.
    std::vector<std::uint32_t> sum = tf_opacity_prefix(p.tf);
    REQUIRE(sum.size() == 257);
    CHECK(sum[0] == 0u);
    CHECK(sum[256] == std::uint32_t(std::count_if(p.tf.begin(), p.tf.end(), [](std::uint32_t c) { return (c >> 24) != 0; })));
}

TEST_CASE("octree DVR: coarser cuts approach the full-resolution image level by level", "[octree][dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({96, 80, 70}, 25);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = params(g, 48, {0.3f, 0.5f, 1.0f}, false, 0.3f);
    Frame full = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);
    REQUIRE(t.levels == 5);
    auto samples = [](const Frame& f) {
        std::uint64_t n = 0;
        for (std::uint32_t s : f.steps) n += s;
        return double(n);
    };
    double previous = 1e9;
    for (std::uint32_t level = 1; level + 1 < t.levels; ++level) {
        Frame cut = render_octree_dvr_cpu(OctreeView{words, t.bricks, level}, p, pool);
        double err = 0.0;
        for (std::size_t i = 0; i < cut.rgba.size(); ++i) err += double(glm::length(cut.rgba[i] - full.rgba[i]));
        // The step follows the level (dt 2^s): about 2^s times fewer samples than the leaves take.
        double ratio = samples(full) / samples(cut), expected = double(1u << (t.levels - 1 - level));
        INFO("level " << level << " error " << err << " sample ratio " << ratio);
        CHECK(err < previous);
        CHECK(err > 0.0);
        CHECK(ratio > 0.6 * expected);
        CHECK(ratio < 1.6 * expected);
        previous = err;
    }
    // Opacity corrected for the longer step: the coarse images keep the full one's total opacity.
    Frame coarse = render_octree_dvr_cpu(OctreeView{words, t.bricks, 2}, p, pool);
    CHECK(opacity_sum(coarse) == Approx(opacity_sum(full)).epsilon(0.1));
}

TEST_CASE("octree DVR: a corrupted index is refused or ends its rays with an error", "[octree][dvr][errors]") {
    volume::DensityGrid g = blobs({20, 20, 20}, 26);
    octree::Tree t = octree::build(g, {4, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = params(g, 16, {0.3f, 0.5f, 1.0f}, false, 0.3f);
    SerialExecutor serial;
    std::vector<std::uint32_t> bad = words;
    bad[0] = 0;
    CHECK_THROWS_AS(render_octree_dvr_cpu(OctreeView{bad, t.bricks}, p, serial), Error);
    bad = words;
    // Every -x neighbour pointing back at its own node: rays crossing a -x face go round in a
    // loop (the root instead would not do: descending from it finds the right leaf again).
    for (std::size_t n = 0; n < t.nodes.size(); ++n) bad[SYLVA_OCT_HEADER_WORDS + 16 * n + 4] = std::uint32_t(n);
    Frame f = render_octree_dvr_cpu(OctreeView{bad, t.bricks}, p, serial);
    CHECK(std::count(f.steps.begin(), f.steps.end(), 0xFFFFFFFFu) > 0);
}

namespace {

/// A uint8 or uint16 volume of the blobs, over its type's range (v / 255 or v / 65535).
volume::Volume integer_blobs(volume::Dims d, std::uint32_t seed, volume::ScalarType type) {
    volume::DensityGrid g = blobs(d, seed);
    volume::Volume v;
    v.type = type;
    v.dims = d;
    const bool u8 = type == volume::ScalarType::U8;
    v.range_lo = 0.0f;
    v.range_hi = u8 ? 255.0f : 65535.0f;
    v.bytes.resize(g.values.size() * (u8 ? 1 : 2));
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        auto q = static_cast<std::uint16_t>(std::lround(g.values[i] * v.range_hi));
        if (u8) v.bytes[i] = std::byte(q);
        else std::memcpy(&v.bytes[2 * i], &q, 2);
    }
    return v;
}

}  // namespace

TEST_CASE("octree DVR and iso: unorm8 / unorm16 bricks of a uint8 / uint16 volume render the native marcher's image bit for bit",
          "[octree][dvr][iso][formats]") {
    ThreadPool pool(2);
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        volume::Volume v = integer_blobs({37, 30, 26}, 27, type);
        volume::DensityGrid g = volume::normalize(v);  // v / 255 or v / 65535, the native sampler's densities
        octree::BrickFormat format = type == volume::ScalarType::U8 ? octree::BrickFormat::Unorm8 : octree::BrickFormat::Unorm16;
        octree::Tree t = octree::build(g, pool, {8, 2, format});
        octree::Tree f32 = octree::build(g, pool, {8, 2});
        std::vector<std::uint32_t> words = octree::encode(t);
        REQUIRE_NOTHROW(octree::validate(words, t.bricks));
        // A quarter (half) of the float32 bricks' words, rounded up per brick.
        std::uint32_t side = 8 + 4, per_word = type == volume::ScalarType::U8 ? 4 : 2;
        CHECK(t.brick_words() == (side * side * side + per_word - 1) / per_word);
        CHECK(t.bricks.size() * per_word >= f32.bricks.size());
        CHECK(t.bricks.size() * per_word < f32.bricks.size() + per_word * t.nodes.size());
        for (std::size_t n = 0; n < t.nodes.size(); ++n) {  // rounding loses nothing: the float32 tree's samples
            REQUIRE(t.nodes[n].min == f32.nodes[n].min);
            REQUIRE(t.nodes[n].max == f32.nodes[n].max);
        }
        std::size_t leaves = 0;  // full-resolution bricks hold the voxels exactly (coarse ones are rounded averages)
        for (std::size_t n = 0; n < t.nodes.size(); ++n) {
            if (t.nodes[n].level + 1 != t.levels) continue;
            ++leaves;
            for (std::uint32_t z = 0; z < side; z += 3)
                for (std::uint32_t x = 0; x < side; ++x)
                    REQUIRE(t.sample(t.nodes[n].brick, x, 5, z) == f32.sample(f32.nodes[n].brick, x, 5, z));
        }
        CHECK(leaves > 10);
        for (GridBorder border : {GridBorder::clamp(), GridBorder{}}) {
            GridWords native = GridWords::native(v, border);
            REQUIRE(native.sampling.format == (type == volume::ScalarType::U8 ? GridFormat::U8 : GridFormat::U16));
            OctreeView view{.words = words, .bricks = t.bricks, .border = border};
            for (bool shading : {false, true}) {
                VolumeRenderParams p = params(g, 48, {0.4f, 0.3f, 1.0f}, shading, 0.3f);
                Frame ref = render_dvr_cpu(native, p, pool);
                Frame oct = render_octree_dvr_cpu(view, p, pool);
                INFO("type " << volume::scalar_name(type) << " border " << int(border.mode) << " shading " << shading);
                CHECK(differing(ref, oct) == 0);
                CHECK(opacity_sum(ref) > 10.0);
            }
            VolumeRenderParams p = params(g, 48, {0.4f, 0.3f, 1.0f}, true, 0.3f);
            p.iso = 0.45f;
            Frame iso = render_octree_iso_cpu(view, p, pool);
            Frame iso_f32 = render_octree_iso_cpu(OctreeView{.words = octree::encode(f32), .bricks = f32.bricks, .border = border}, p, pool);
            CHECK(differing(iso, iso_f32) == 0);
        }
    }
    // Densities that are not k / 255 are rounded to the nearest step: within half a step of the
    // float32 tree's samples, and the ranges those of the rounded samples.
    volume::DensityGrid g = blobs({20, 20, 20}, 28);
    octree::Tree t = octree::build(g, pool, {8, 1, octree::BrickFormat::Unorm8});
    octree::Tree f32 = octree::build(g, pool, {8, 1});
    float worst = 0.0f;
    for (std::uint32_t b = 0; b < f32.brick_count(); ++b)
        for (std::uint32_t x = 0; x < 10; ++x) worst = std::max(worst, std::abs(t.sample(b, x, 4, 6) - f32.sample(b, x, 4, 6)));
    CHECK(worst > 0.0f);
    CHECK(worst <= 0.5f / 255.0f + 1e-7f);
    CHECK(t.nodes[0].min == std::round(f32.nodes[0].min * 255.0f) / 255.0f);
    CHECK(t.nodes[0].max == std::round(f32.nodes[0].max * 255.0f) / 255.0f);
    octree::Config bad{8, 2, static_cast<octree::BrickFormat>(1)};
    CHECK_THROWS_WITH(octree::build(g, pool, bad), Catch::Contains("unknown brick format 1"));
}

TEST_CASE("octree DVR with a TF hook skips what the hook's visibility query rules out, the image unchanged",
          "[octree][dvr][tf]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({64, 64, 64}, 24);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = params(g, 48, {0.3f, 0.5f, 1.0f}, true, 0.55f);
    p.tf_kind = TfKind::Hook;
    p.tf_hook = [](float d) { return vec4(d, 0.5f, 1.0f - d, d <= 0.55f ? 0.0f : (d - 0.55f) * 0.6f); };
    Frame ref = render_dvr_cpu(GridWords::from(g), p, pool);
    Frame blind = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);  // no query: nothing skipped by the TF
    VolumeRenderParams q = p;
    q.tf_hook_visible = [](float, float hi) { return hi > 0.55f; };
    REQUIRE(tf_skip_entries(q) == kHookSkipEntries);
    Frame skipping = render_octree_dvr_cpu(OctreeView{words, t.bricks}, q, pool);
    std::vector<std::uint32_t> masks = octree::octant_masks(octree::octant_ranges(words, t.bricks, pool), tf_opacity_prefix(q), 0.0f);
    Frame masked = render_octree_dvr_cpu(OctreeView{words, t.bricks, 0xFFFFFFFFu, {}, masks}, q, pool);
    CHECK(differing(ref, blind) == 0);
    CHECK(differing(ref, skipping) == 0);
    CHECK(differing(ref, masked) == 0);
    CHECK(opacity_sum(ref) > 10.0);
    INFO("samples: no query " << total_samples(blind) << ", query " << total_samples(skipping) << ", with octants "
                              << total_samples(masked));
    CHECK(total_samples(skipping) < total_samples(blind) * 3 / 4);
    CHECK(total_samples(masked) < total_samples(skipping));
    // A query that lies (claims nothing is visible) is what skips: the image then loses the blobs.
    VolumeRenderParams liar = p;
    liar.tf_hook_visible = [](float, float) { return false; };
    CHECK(opacity_sum(render_octree_dvr_cpu(OctreeView{words, t.bricks}, liar, pool)) == 0.0);
}
