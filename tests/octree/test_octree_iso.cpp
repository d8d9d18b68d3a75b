// First-hit isosurfaces over the bricked octree (sylva/shared/octree_iso.h): with the
// full-resolution cut the image equals a grid iso marcher's (written here from the grid's own
// sampling: first lattice point reaching iso, bisection, central-difference shading) bit for bit;
// range culling skips leaves without changing the image; coarser cuts converge to it.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/shared/dvr.h>
#include <sylva/volume/procedural.hpp>

#include "frames.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

/// The grid iso marcher: over the marcher's span, the first lattice point t_k whose
/// sylva_grid_sample (p's border mode) reaches iso; bisected 10 times against t_(k-1) when that
/// lies in the span; shaded with sylva_grid_sample_gradient in the TF's colour at iso.
vec4 grid_iso(shared::Words gw, shared::Words tw, const shared::SylvaDvrParams& p, vec3 o, vec3 dir, std::uint32_t& steps) {
    using namespace sylva::shared;
    steps = 0;
    vec3 d = sylva_dvr_unit(dir);
    vec2 span = sylva_dvr_clip(vec3(0.0f), sylva_dvr_grid_hi(p), o, d, 0.0f, sylva_inf());
    if (!(span.x <= span.y)) return vec4(0.0f);
    SylvaGridDesc g = sylva_dvr_grid(p);
    auto density = [&](float t) { return sylva_grid_sample(gw, g, sylva_dvr_at(o, d, t)); };
    for (std::uint32_t k = sylva_lattice_first(span.x, p.dt);; ++k) {
        float t = sylva_lattice_t(k, p.dt);
        if (!(t < span.y)) return vec4(0.0f);
        ++steps;
        if (density(t) < p.iso) continue;
        float hit = t;
        if (k > 0 && sylva_lattice_t(k - 1, p.dt) >= span.x) {
            float lo = sylva_lattice_t(k - 1, p.dt), hi = t;
            for (int i = 0; i < 10; ++i) {
                float mid = 0.5f * (lo + hi);
                (density(mid) >= p.iso ? hi : lo) = mid;
            }
            hit = hi;
        }
        vec4 c = sylva_tf_lookup(tw, p.tf_entries, p.iso);
        vec3 gr = sylva_grid_sample_gradient(gw, g, sylva_dvr_at(o, d, hit));
        SylvaDvrParams lit = p;
        lit.flags |= SYLVA_DVR_FLAG_SHADING;
        vec3 rgb = sylva_dvr_shade(lit, vec3(c), vec3(gr.x / p.spacing.x, gr.y / p.spacing.y, gr.z / p.spacing.z), d);
        return vec4(rgb, 1.0f);
    }
}

template <class X>
Frame render_grid_iso(const volume::DensityGrid& g, const VolumeRenderParams& p, X& exec, GridBorder border = GridBorder::clamp()) {
    GridWords gw = GridWords::from(g, border);
    std::vector<std::uint32_t> words = dvr_params(gw, p);
    shared::Words pw{words.data(), words.size()}, grid{gw.words.data(), gw.words.size()}, tw{p.tf.data(), p.tf.size()};
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    return detail::render_pixels(p, exec, [&](vec3 o, vec3 d, std::uint32_t& steps) { return grid_iso(grid, tw, sp, o, d, steps); });
}

VolumeRenderParams iso_params(const volume::DensityGrid& g, std::uint32_t size, vec3 view, float iso) {
    VolumeRenderParams p;
    p.camera = Camera::framing(g.world_box(), view, 35.0f).frame(size, size);
    p.width = p.height = size;
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = (40 + i * 3 / 4) | ((230 - i / 2) << 8) | (120u << 16) | (255u << 24);
    p.iso = iso;
    return p;
}

}  // namespace

TEST_CASE("octree iso: the full-resolution cut renders the grid iso marcher's image bit for bit", "[octree][iso]") {
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        octree::Config cfg;
        vec3 view;
        float iso;
    };
    std::vector<Case> cases;
    cases.push_back({blobs({33, 17, 70}, 21), {16, 2}, {0.4f, 0.3f, 1.0f}, 0.45f});
    cases.push_back({blobs({45, 40, 38}, 22, vec3(1.0f, 0.5f, 2.0f)), {32, 2}, {-0.7f, 0.2f, -0.5f}, 0.45f});
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {8, 2}, {0.1f, 1.0f, 0.2f}, 0.5f});
    cases.push_back({blobs({70, 9, 20}, 23), {4, 2}, {1.0f, 0.0f, 0.0f}, 0.4f});  // axis-aligned: rays in leaf planes
    std::size_t pixels = 0, hits = 0, border_hits[2] = {0, 0};
    std::uint64_t ref_steps = 0, oct_steps = 0;
    for (const Case& c : cases) {
        octree::Tree t = octree::build(c.grid, pool, c.cfg);
        std::vector<std::uint32_t> words = octree::encode(t);
        VolumeRenderParams p = iso_params(c.grid, 64, c.view, c.iso);
        // Both constant borders: 0 (the default) and 1, which puts a surface on the volume's faces
        // (at a face samples blend to (v + 1) / 2 >= iso; face leaves must not be culled by their
        // voxels' range).
        for (GridBorder border : {GridBorder{}, GridBorder::constant(1.0f)}) {
            Frame ref = render_grid_iso(c.grid, p, pool, border);
            Frame oct = render_octree_iso_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = border}, p, pool);
            INFO(c.grid.dims.x << "x" << c.grid.dims.y << "x" << c.grid.dims.z << " B " << c.cfg.brick_size << " border "
                               << border.value);
            CHECK(differing(ref, oct) == 0);
            CHECK(total_samples(oct) <= total_samples(ref));
            for (const vec4& v : ref.rgba) border_hits[border.value > 0.0f ? 1 : 0] += v.w == 1.0f ? 1 : 0;
        }
        Frame ref = render_grid_iso(c.grid, p, pool);
        Frame oct = render_octree_iso_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = GridBorder::clamp()}, p, pool);
        INFO(c.grid.dims.x << "x" << c.grid.dims.y << "x" << c.grid.dims.z << " B " << c.cfg.brick_size);
        CHECK(differing(ref, oct) == 0);
        pixels += ref.rgba.size();
        for (const vec4& v : ref.rgba) hits += v.w == 1.0f ? 1 : 0;
        CHECK(total_samples(oct) <= total_samples(ref));
        ref_steps += total_samples(ref);
        oct_steps += total_samples(oct);
    }
    // Range culling: fewer samples than the marcher's (which tests every lattice point).
    CHECK(oct_steps < ref_steps);
    INFO("hits with border 0: " << border_hits[0] << ", with border 1: " << border_hits[1]);
    CHECK(border_hits[1] > border_hits[0] + 500);  // the faces' surface shows
    CHECK(hits > pixels / 8);
    CHECK(hits < pixels * 9 / 10);
}

TEST_CASE("octree iso: range culling skips leaves, the image unchanged", "[octree][iso]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({64, 64, 64}, 24);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    std::vector<std::uint32_t> uncull = words;  // every node's max raised to 1: nothing culled
    for (std::size_t n = 0; n < t.nodes.size(); ++n) uncull[SYLVA_OCT_HEADER_WORDS + 16 * n + 11] = std::bit_cast<std::uint32_t>(1.0f);
    VolumeRenderParams p = iso_params(g, 48, {0.3f, 0.5f, 1.0f}, 0.6f);
    Frame culled = render_octree_iso_cpu(OctreeView{words, t.bricks}, p, pool);
    Frame all = render_octree_iso_cpu(OctreeView{uncull, t.bricks}, p, pool);
    CHECK(differing(culled, all) == 0);
    INFO("samples culled " << total_samples(culled) << ", not culled " << total_samples(all));
    CHECK(total_samples(culled) < total_samples(all) * 3 / 4);
    std::size_t hits = 0;
    for (const vec4& v : culled.rgba) hits += v.w == 1.0f ? 1 : 0;
    CHECK(hits > 200);
    // A wrong range (max below the data) does change it: the culling is what skips.
    std::vector<std::uint32_t> wrong = words;
    for (std::size_t n = 0; n < t.nodes.size(); ++n) wrong[SYLVA_OCT_HEADER_WORDS + 16 * n + 11] = std::bit_cast<std::uint32_t>(0.1f);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) wrong[SYLVA_OCT_HEADER_WORDS + 16 * n + 10] = std::bit_cast<std::uint32_t>(0.0f);
    CHECK(differing(render_octree_iso_cpu(OctreeView{wrong, t.bricks}, p, pool), all) > 200);
}

TEST_CASE("octree iso: coarser cuts converge to the full-resolution surface", "[octree][iso][cut]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({96, 80, 70}, 25);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p = iso_params(g, 64, {0.3f, 0.5f, 1.0f}, 0.55f);
    Frame full = render_octree_iso_cpu(OctreeView{words, t.bricks}, p, pool);
    std::vector<std::size_t> diff;
    for (float lod : {8.0f, 2.0f, 0.5f, 0.125f, 1e-6f}) {
        std::vector<std::uint32_t> w = words;
        octree::Cut c = select_octree_cut(w, p, {lod, 0xFFFFFFFFu}, true);
        octree::apply_cut(w, c);
        Frame f = render_octree_iso_cpu(OctreeView{w, t.bricks}, p, pool);
        std::size_t n = 0;
        for (std::size_t i = 0; i < f.rgba.size(); ++i) n += glm::length(f.rgba[i] - full.rgba[i]) > 0.02f ? 1 : 0;
        diff.push_back(n);
    }
    INFO("pixels off by > 0.02: " << diff[0] << " " << diff[1] << " " << diff[2] << " " << diff[3] << " " << diff[4]);
    CHECK(diff.back() == 0);
    CHECK(diff[0] > 100);  // the coarsest cut does differ
    for (std::size_t i = 1; i < diff.size(); ++i) CHECK(diff[i] <= diff[0] * 11 / 10);
    CHECK(diff[2] < diff[0] / 10);
}
