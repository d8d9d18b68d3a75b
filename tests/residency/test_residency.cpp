// The out-of-core working set (sylva/octree/residency.hpp) with the host renderer: progressive
// renders converge to the in-core octree's image of the same cut, bit for bit; budgets hold at
// every step; bad bricks are reported once and their parent drawn; the visibility feedback marks
// exactly the leaves the rays reached (a host reference walk).
#include <catch2/catch.hpp>

#include <set>

#include <sylva/octree/validate.hpp>

#include "fault_source.hpp"
#include "scene.hpp"

using namespace sylva;
using namespace residency_test;

namespace {

/// Runs frames until nothing is requested, uploaded or loading (or `max` frames); the last
/// frame's image. wait: let the loader finish between frames (deterministic).
template <class Res>
Frame converge(Res& res, octree::HostBrickPool& pool, const VolumeRenderParams& p, const OctreeTerminal& term,
               ThreadPool& exec, bool wait, int max, int& frames) {
    Frame f;
    for (frames = 1; frames <= max; ++frames) {
        f = ooc_frame(res, pool, p, term, exec);
        const octree::ResidencyFrame& r = res.frame();
        if (wait) res.wait_loads();
        if (frames > 2 && r.requests == 0 && r.uploads == 0 && r.waiting == 0) break;
    }
    return f;
}

}  // namespace

TEST_CASE("progressive render without feedback converges to the in-core image of select_octree_cut's cut", "[residency]") {
    volume::DensityGrid g = octree_test::blobs({70, 60, 50}, 11);
    octree::Tree t = octree::build(g, {8, 2});
    VolumeRenderParams p = params_for(g, {0.5f, 0.4f, 1.0f});
    ThreadPool exec(2);
    octree::CutConfig cc{0.5f, 1u << 20};
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::Cut ref_cut = select_octree_cut(words, p, cc, false);
    REQUIRE(ref_cut.deepest >= 3);
    Frame ref = in_core(t, ref_cut, p, exec);
    for (bool wait : {true, false}) {
        FaultySource src(t, {}, {}, std::chrono::microseconds(wait ? 0 : 200));
        octree::ResidencyConfig cfg;
        cfg.lod_pixels = cc.lod_pixels;
        cfg.visibility_feedback = false;
        cfg.max_uploads_per_frame = 16;  // several frames of uploads
        octree::HostBrickPool pool(octree::pool_slots(src.index(), cfg), src.index()[8]);
        octree::Residency res(src, pool, cfg);
        OctreeTerminal term(src.index(), p, false);
        int frames = 0;
        Frame first = ooc_frame(res, pool, p, term, exec);
        CHECK(res.frame().cut.nodes == 1);  // only the root is resident before the first frame
        Frame f = converge(res, pool, p, term, exec, wait, 2000, frames);
        INFO("wait " << wait << ", frames " << frames);
        REQUIRE(frames < 2000);
        CHECK(frames > 3);  // progressive: the upload budget spreads the work
        CHECK(res.frame().cut.state == ref_cut.state);
        CHECK(same_pixels(f, ref));
        CHECK(f.steps == ref.steps);
        CHECK_FALSE(same_pixels(first, ref));
        CHECK(res.counters().bad_bricks == 0);
    }
}

TEST_CASE("progressive render with visibility feedback draws the in-core image of its own cut, and close to the full cut's",
          "[residency][feedback]") {
    volume::DensityGrid g = octree_test::blobs({70, 60, 50}, 12);
    octree::Tree t = octree::build(g, {8, 2});
    VolumeRenderParams p = params_for(g, {0.3f, 0.5f, 1.0f});
    p.tf.assign(256, 0u);  // nearly opaque above 0.5: rays stop early, the back is hidden
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = 0x00C0A080u | ((i < 128 ? 0u : 250u) << 24);
    ThreadPool exec(2);
    octree::CutConfig cc{0.5f, 1u << 20};
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::Cut full_cut = select_octree_cut(words, p, cc, false);
    Frame full = in_core(t, full_cut, p, exec);
    octree::TreeBrickSource src(t);
    octree::ResidencyConfig cfg;
    cfg.lod_pixels = cc.lod_pixels;
    octree::HostBrickPool pool(octree::pool_slots(src.index(), cfg), src.index()[8]);
    octree::Residency res(src, pool, cfg);
    OctreeTerminal term(src.index(), p, false);
    int frames = 0;
    Frame f = converge(res, pool, p, term, exec, true, 200, frames);
    REQUIRE(frames < 200);
    const octree::Cut& cut = res.frame().cut;
    CHECK(same_pixels(f, in_core(t, cut, p, exec)));
    CHECK(cut.nodes < full_cut.nodes);  // hidden nodes were not refined
    CHECK(res.counters().feedback_blocked > 0);
    std::size_t differ = 0;
    double max_diff = 0.0;
    for (std::size_t i = 0; i < f.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) {
            double d = std::abs(double(f.rgba[i][c]) - double(full.rgba[i][c]));
            max_diff = std::max(max_diff, d);
            differ += d > 0.0 ? 1u : 0u;
        }
    INFO("cut " << cut.nodes << " nodes of the full cut's " << full_cut.nodes << "; channels differing " << differ
                << ", max " << max_diff);
    CHECK(max_diff < 2.0 / 255.0);
}

TEST_CASE("budgets hold at every step of an orbit, and every drawn brick is resident and holds its node's brick", "[residency][budget]") {
    volume::DensityGrid g = octree_test::blobs({64, 64, 64}, 13);
    octree::Tree t = octree::build(g, {8, 2});
    const std::size_t bb = std::size_t{t.brick_words()} * 4;
    FaultySource src(t, {}, {}, std::chrono::microseconds(50));
    ThreadPool exec(2);
    for (std::size_t device_bricks : {12u, 40u}) {  // 12: root + 8 children + 3; 40: replacement
        octree::ResidencyConfig cfg;
        cfg.lod_pixels = 0.25f;
        cfg.host_budget_bytes = 30 * bb + 100;
        cfg.device_budget_bytes = device_bricks * bb + 7;
        cfg.max_uploads_per_frame = 6;
        octree::HostBrickPool pool(octree::pool_slots(src.index(), cfg), src.index()[8]);
        REQUIRE(pool.words.size() == device_bricks * t.brick_words());
        octree::Residency res(src, pool, cfg);
        VolumeRenderParams p = params_for(g, {1.0f, 0.3f, 0.0f});
        OctreeTerminal term(src.index(), p, false);
        std::uint32_t deepest = 0;
        for (int frame = 0; frame < 60; ++frame) {
            float a = 0.1f * float(frame);
            p = params_for(g, {std::cos(a), 0.3f, std::sin(a)});
            (void)ooc_frame(res, pool, p, term, exec);
            const octree::ResidencyFrame& f = res.frame();
            REQUIRE(res.pinned() <= res.slots());
            REQUIRE(f.resident <= res.slots());
            REQUIRE(res.host_counters().bytes <= cfg.host_budget_bytes);
            REQUIRE(res.host_counters().peak_bytes <= cfg.host_budget_bytes);
            REQUIRE_NOTHROW(octree::validate(f.words, pool.words));
            deepest = std::max(deepest, f.cut.deepest);
            for (std::uint32_t n = 0; n < t.nodes.size(); ++n) {
                std::size_t at = SYLVA_OCT_HEADER_WORDS + 16 * std::size_t{n};
                std::uint32_t state = (f.words[at + 1] >> 16) & 3u;
                if (f.cut.state[n] == octree::CutState::Leaf && !term(n)) REQUIRE(state == SYLVA_OCT_BRICK_RESIDENT);
                if (state == SYLVA_OCT_BRICK_RESIDENT) {
                    std::uint32_t slot = f.words[at + 12], key = t.nodes[n].brick, w = t.brick_words();
                    REQUIRE(std::equal(pool.words.begin() + std::ptrdiff_t(std::size_t{slot} * w),
                                       pool.words.begin() + std::ptrdiff_t(std::size_t{slot + 1} * w),
                                       t.bricks.begin() + std::ptrdiff_t(std::size_t{key} * w)));
                }
            }
        }
        INFO("device bricks " << device_bricks);
        CHECK(deepest >= (device_bricks > 12 ? 2u : 1u));
        if (device_bricks > 12) {
            CHECK(res.counters().device_evicted > 0);
            CHECK(res.host_counters().evicted > 0);
        }
    }
}

TEST_CASE("a corrupt or missing brick is reported once, never read again, and its parent is drawn", "[residency][faults]") {
    volume::DensityGrid g = octree_test::blobs({64, 64, 64}, 14);
    octree::Tree t = octree::build(g, {8, 2});
    // A node at level 2 and one at level 3 (in another branch) that the view refines.
    std::uint32_t corrupt_node = 0, missing_node = 0;
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n) {
        if (!corrupt_node && t.nodes[n].level == 2 && !t.nodes[n].leaf()) corrupt_node = n;
        if (t.nodes[n].level == 3) missing_node = n;  // the last one
    }
    REQUIRE(corrupt_node);
    REQUIRE(missing_node);
    std::uint32_t ck = t.nodes[corrupt_node].brick, mk = t.nodes[missing_node].brick;
    FaultySource src(t, {ck}, {mk});
    ThreadPool exec(2);
    VolumeRenderParams p = params_for(g, {0.5f, 0.4f, 1.0f});
    p.tf.assign(256, 0x20C0A080u);  // every node visible: the whole octree is wanted
    octree::ResidencyConfig cfg;
    cfg.lod_pixels = 0.05f;
    cfg.report_bad_bricks = false;  // counted, not printed, in this test
    octree::HostBrickPool pool(octree::pool_slots(src.index(), cfg), src.index()[8]);
    octree::Residency res(src, pool, cfg);
    OctreeTerminal term(src.index(), p, false);
    int frames = 0;
    Frame f = converge(res, pool, p, term, exec, true, 300, frames);
    REQUIRE(frames < 300);
    const octree::Cut& cut = res.frame().cut;
    CHECK(res.counters().bad_bricks == 2);
    CHECK(res.bad(ck));
    CHECK(res.bad(mk));
    CHECK(src.reads(ck) == 1);
    CHECK(src.reads(mk) == 1);
    CHECK(cut.state[corrupt_node] == octree::CutState::Below);
    CHECK(cut.state[missing_node] == octree::CutState::Below);
    auto parent_of = [&](std::uint32_t c) {
        for (std::uint32_t n = 0; n < t.nodes.size(); ++n)
            if (t.nodes[n].first_child != octree::kNone && c >= t.nodes[n].first_child &&
                c < t.nodes[n].first_child + std::popcount(t.nodes[n].child_mask))
                return n;
        return 0u;
    };
    CHECK(cut.state[parent_of(corrupt_node)] == octree::CutState::Leaf);
    CHECK(cut.state[parent_of(missing_node)] == octree::CutState::Leaf);
    CHECK(cut.deepest == t.levels - 1);  // elsewhere the cut reached the leaves
    CHECK(same_pixels(f, in_core(t, cut, p, exec)));  // no corrupt voxel drawn
}

TEST_CASE("visibility feedback marks exactly the cut leaves the rays reached before terminating", "[residency][feedback]") {
    volume::DensityGrid g = octree_test::blobs({56, 48, 40}, 15);
    octree::Tree t = octree::build(g, {8, 2});
    ThreadPool exec(2);
    VolumeRenderParams p = params_for(g, {0.2f, 0.6f, 1.0f}, 40, 30);
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = 0x00C0A080u | ((i < 110 ? 0u : 200u) << 24);
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::apply_cut(words, select_octree_cut(words, p, {0.7f, 1u << 20}, false));
    std::vector<std::uint32_t> seen(t.nodes.size(), 0u);
    Frame f = render_octree_dvr_cpu(OctreeView{words, t.bricks, 0xFFFFFFFFu, seen}, p, exec);
    // Reference: per pixel, the first `visits` leaves of the walk (sylva_oct_dvr_ray's count).
    std::vector<std::uint32_t> params = octree_dvr_params(OctreeView{words, t.bricks}, p);
    std::vector<std::uint32_t> tfsum = tf_opacity_prefix(p.tf);
    shared::Words ow{words.data(), words.size()}, bw{t.bricks.data(), t.bricks.size()}, tw{p.tf.data(), p.tf.size()},
        sw{tfsum.data(), tfsum.size()}, pw{params.data(), params.size()};
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(ow, std::uint32_t(words.size()), std::uint32_t(t.bricks.size()));
    std::set<std::uint32_t> expect;
    std::size_t terminated = 0;
    for (std::uint32_t y = 0; y < p.height; ++y)
        for (std::uint32_t x = 0; x < p.width; ++x) {
            Ray r = p.camera.ray(x, y, p.width, p.height);
            std::uint32_t steps, visits, status;
            shared::sylva_oct_dvr_ray(ow, bw, tw, sw, sp, h, 0xFFFFFFFFu, r.origin, r.direction, 0.0f, shared::sylva_inf(),
                                      steps, visits, status);
            vec3 d = shared::sylva_dvr_unit(r.direction);
            vec3 hi = vec3(g.dims) * g.spacing;
            vec2 span = shared::sylva_dvr_clip(vec3(0.0f), hi, r.origin, d, 0.0f, shared::sylva_inf());
            if (!(span.x <= span.y)) continue;
            shared::SylvaOctIter it;
            shared::sylva_oct_begin(it, h, r.origin, d, span.x, span.y, 0xFFFFFFFFu);
            std::uint32_t node, k = 0;
            float t0, t1;
            while (k < visits && shared::sylva_oct_next(it, ow, node, t0, t1)) {
                expect.insert(node);
                ++k;
            }
            if (it.status == SYLVA_ITER_RUNNING) ++terminated;
        }
    std::set<std::uint32_t> got;
    for (std::uint32_t n = 0; n < seen.size(); ++n)
        if (seen[n]) got.insert(n);
    CHECK(got == expect);
    CHECK(terminated > 0);  // some rays stopped early: the set is not just "every leaf on a ray"
    std::size_t leaves = 0;
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n) leaves += (words[SYLVA_OCT_HEADER_WORDS + 16 * n + 1] & SYLVA_OCT_CUT_LEAF) ? 1 : 0;
    CHECK(got.size() < leaves);
    CHECK(!got.empty());
    (void)f;
}

TEST_CASE("progressive first-hit iso converges to the in-core iso image of the same cut", "[residency][iso]") {
    volume::DensityGrid g = octree_test::blobs({60, 52, 44}, 16);
    octree::Tree t = octree::build(g, {8, 2});
    VolumeRenderParams p = params_for(g, {0.6f, 0.3f, 1.0f});
    p.iso = 0.55f;
    ThreadPool exec(2);
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::Cut ref_cut = select_octree_cut(words, p, {0.5f, 1u << 20}, true);
    REQUIRE(ref_cut.deepest >= 2);
    octree::apply_cut(words, ref_cut);
    Frame ref = render_octree_iso_cpu(OctreeView{words, t.bricks}, p, exec);
    octree::TreeBrickSource src(t);
    octree::ResidencyConfig cfg;
    cfg.lod_pixels = 0.5f;
    cfg.visibility_feedback = false;
    octree::HostBrickPool pool(octree::pool_slots(src.index(), cfg), src.index()[8]);
    octree::Residency res(src, pool, cfg);
    OctreeTerminal term(src.index(), p, true);
    Frame f;
    int frames = 0;
    for (frames = 1; frames < 100; ++frames) {
        const octree::ResidencyFrame& r = res.update(octree::cut_view(p.camera, p.width, p.height), term);
        f = render_octree_iso_cpu(OctreeView{r.words, pool.words, 0xFFFFFFFFu, res.feedback()}, p, exec);
        res.wait_loads();
        if (frames > 2 && r.requests == 0 && r.uploads == 0 && r.waiting == 0) break;
    }
    REQUIRE(frames < 100);
    CHECK(res.frame().cut.state == ref_cut.state);
    CHECK(same_pixels(f, ref));
    std::size_t hits = 0;
    for (const vec4& c : f.rgba) hits += c.w > 0.0f ? 1u : 0u;
    CHECK(hits > f.rgba.size() / 20);  // the surface covers 290 of 3072 pixels
}
