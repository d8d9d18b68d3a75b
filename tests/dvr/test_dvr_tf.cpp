// Transfer functions beyond the RGBA8 table (sylva/shared/tf.h, sylva/shared/dvr_classify.h):
// float RGBA tables of any size, the host hook (the analytic TF from one shared-subset
// text, tests/dvr/shaders/analytic_tf.h), and the selectable opacity correction.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstring>
#include <random>

#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/octree_volume.hpp>

#include "dvr_fixtures.hpp"
#include "shaders/analytic_tf.h"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

std::size_t differing_bits(const Frame& a, const Frame& b, bool steps = true) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        n += (std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0 || (steps && a.steps[i] != b.steps[i])) ? 1 : 0;
    return n;
}

double summed_alpha(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.a;
    return s;
}

/// The analytic TF written plainly in C++ (no shared code).
float analytic_alpha(float d) { return std::clamp((d - 0.1f) / 0.9f, 0.0f, 1.0f) * 0.4f; }

std::vector<std::uint32_t> f32_words(const std::vector<float>& t) {
    std::vector<std::uint32_t> w(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) w[i] = std::bit_cast<std::uint32_t>(t[i]);
    return w;
}

}  // namespace

TEST_CASE("TF hook: the shared-subset analytic TF equals the formula bit for bit", "[dvr][tf]") {
    std::function<vec4(float)> hook = [](float d) { return shared::sylva_tf_user(d); };
    std::uint32_t dummy = 0;
    shared::Words tw{&dummy, 1, &hook};
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> u(-0.2f, 1.2f);
    std::vector<float> ds{0.0f, 0.1f, std::nextafter(0.1f, 1.0f), 0.5f, 1.0f, 1.5f, -0.0f};
    for (int i = 0; i < 100000; ++i) ds.push_back(u(rng));
    for (int v = 0; v < 256; ++v) ds.push_back(float(v) / 255.0f);
    for (float d : ds) {
        vec4 c = shared::sylva_tf_classify(tw, SYLVA_TF_KIND_HOOK, 0u, d);
        INFO("d " << d);
        REQUIRE(std::bit_cast<std::uint32_t>(c.a) == std::bit_cast<std::uint32_t>(analytic_alpha(d)));
        REQUIRE(c.r == 1.0f);
    }
    shared::Words none{&dummy, 1};
    CHECK(shared::sylva_tf_classify(none, SYLVA_TF_KIND_HOOK, 0u, 0.5f) == vec4(0.0f));  // no hook: transparent
}

TEST_CASE("Float RGBA tables: any size, linear between entries, clamped at the ends", "[dvr][tf]") {
    std::vector<float> one{0.25f, 0.5f, 0.75f, 0.3f};
    std::vector<std::uint32_t> w1 = f32_words(one);
    for (float d : {-1.0f, 0.0f, 0.4f, 1.0f, 3.0f})
        CHECK(shared::sylva_tf_lookup_f32(shared::Words{w1.data(), w1.size()}, 1u, d) == vec4(0.25f, 0.5f, 0.75f, 0.3f));
    std::vector<float> three{0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.5f, 0.25f, 0.5f, 0.0f, 1.0f, 1.0f, 1.0f};
    std::vector<std::uint32_t> w3 = f32_words(three);
    shared::Words t3{w3.data(), w3.size()};
    for (double d : {0.0, 0.1, 0.25, 0.5, 0.6, 0.9, 1.0}) {
        double x = d * 2.0;
        std::size_t i = std::min<std::size_t>(std::size_t(x), 2), j = std::min<std::size_t>(i + 1, 2);
        double f = x - double(i);
        vec4 c = shared::sylva_tf_lookup_f32(t3, 3u, float(d));
        for (int k = 0; k < 4; ++k) CHECK(c[k] == Approx(three[i * 4 + k] + (three[j * 4 + k] - three[i * 4 + k]) * f).margin(1e-6));
    }
    CHECK(shared::sylva_tf_lookup_f32(t3, 3u, std::nanf("")) == vec4(0.0f));
    CHECK(shared::sylva_tf_lookup_f32(t3, 0u, 0.5f) == vec4(0.0f));
}

TEST_CASE("Constant slab: float tables, the hook and both opacity corrections give the analytic opacity",
          "[dvr][tf]") {
    // 16 x 8 x 4 voxels of density 1 as voxel cuboids (density exactly 1 everywhere inside: no
    // trilinear border, no payload rounding), multi-sample BIH-DVR with orthographic rays along
    // -z (test_dvr_rays.cpp) and dt = 0.5: n = 6 lattice samples inside, each of the TF's alpha a
    // at density 1. Power: 1 - (1 - a)^(n dt / unit); None: 1 - (1 - a)^n.
    volume::DensityGrid g = sample_grid({16, 8, 4}, {1.0f, 1.5f, 0.75f}, [&](glm::dvec3) { return 1.0; });
    GridWords gw = GridWords::from(g);
    auto words = encode_voxels(grid_cuboids(g, 0.1f), bih::NodeFormat::Float32);
    VoxelBihView view{words, {}, g.spacing, gw.world_box()};
    VolumeRenderParams p;
    p.mode = VolumeMode::BihMulti;
    p.width = 40;
    p.height = 30;
    p.unit = 2.0f;
    p.alpha_stop = 2.0f;
    p.camera = CameraFrame{vec3(8.0f, 6.0f, 10.0f), vec3(0.0f, 0.0f, -1.0f), vec3(10.0f, 0.0f, 0.0f), vec3(0.0f, 7.5f, 0.0f)};
    p.rays.source = RaySource::Ortho;
    ThreadPool pool(2);
    const float dt = 0.5f;
    p.dt = dt;
    std::size_t n = 0;
    for (std::uint32_t k = 0; float(k) * dt < 10.0f; ++k) n += float(k) * dt >= 7.0f ? 1 : 0;
    const std::size_t centre = 15 * 40 + 20;
    struct Case {
        const char* name;
        TfKind kind;
        std::vector<float> table;
        double alpha;
    };
    std::vector<Case> cases{
        {"1-entry float table", TfKind::Rgba32f, {0.9f, 0.6f, 0.3f, 0.3f}, 0.3},
        {"5-entry float table", TfKind::Rgba32f, {0, 0, 0, 0, 0, 0, 0, 0.1f, 1, 1, 1, 1, 0.2f, 0.2f, 0.2f, 0.9f, 0.9f, 0.6f, 0.3f, 0.3f},
         0.3},
        {"hook", TfKind::Hook, {}, 0.4},
    };
    for (const Case& c : cases) {
        for (OpacityCorrection oc : {OpacityCorrection::Power, OpacityCorrection::None}) {
            VolumeRenderParams q = p;
            q.tf_kind = c.kind;
            q.tf_rgba32f = c.table;
            q.tf_hook = [](float d) { return shared::sylva_tf_user(d); };
            q.opacity = oc;
            Frame f = render_bih_dvr_cpu(view, q, pool);
            double e = oc == OpacityCorrection::Power ? double(n) * dt / q.unit : double(n);
            double expect = 1.0 - std::pow(1.0 - c.alpha, e);
            INFO(c.name << (oc == OpacityCorrection::Power ? " power" : " none") << " n " << n);
            CHECK(f.rgba[centre].a == Approx(expect).margin(4e-6));
            CHECK(f.rgba[0].a == 0.0f);
            CHECK(n == 6u);
        }
    }
}

TEST_CASE("A float table equal to the RGBA8 texels renders the RGBA8 image bit for bit; hooks render everywhere",
          "[dvr][tf]") {
    ThreadPool pool(2);
    volume::Dims dims{24, 20, 18};
    vec3 spacing{1.0f, 1.1f, 1.2f};
    volume::DensityGrid grid = sample_grid(dims, spacing, blobs(vec3(dims) * spacing));
    GridWords gw = GridWords::from(grid);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    VoxelBihView view{bih, {}, spacing, grid.world_box()};
    VolumeRenderParams p;
    p.width = 40;
    p.height = 32;
    p.camera = Camera::framing(grid.world_box(), vec3(0.5f, 0.35f, 1.0f), 36.0f).frame(p.width, p.height);
    p.tf = smooth_tf(0.08f, 0.3f);
    p.shading = true;
    std::vector<std::uint32_t> kd = kdtree::encode(kdtree::build_vidal(
        ess_occupancy(ess_codes(grid, 256u, pool), ess_classifier(p.tf), pool), kdtree::Config::deep()));
    octree::Tree oct = octree::build(grid, pool, {8, 2});
    std::vector<std::uint32_t> oct_words = octree::encode(oct);
    VolumeRenderParams pf = p;
    pf.tf_kind = TfKind::Rgba32f;
    for (std::uint32_t c : p.tf)
        for (std::uint32_t k = 0; k < 4; ++k) pf.tf_rgba32f.push_back(float((c >> (8 * k)) & 255u) * (1.0f / 255.0f));
    VolumeRenderParams ph = p;  // the hook: the RGBA8 table's lookup as a callable
    ph.tf_kind = TfKind::Hook;
    ph.tf_hook = [tf = p.tf](float d) { return shared::sylva_tf_lookup(shared::Words{tf.data(), tf.size()}, 256u, d); };
    // The octree skips no node by a hook (its zeros are unknown): the same colours, more steps.
    auto same = [&](auto render, bool hook_steps = true) {
        Frame a = render(p), b = render(pf), c = render(ph);
        CHECK(summed_alpha(a) > 10.0);
        CHECK(differing_bits(a, b) == 0);
        CHECK(differing_bits(a, c, hook_steps) == 0);
    };
    same([&](const VolumeRenderParams& q) { return render_dvr_cpu(gw, q, pool); });
    for (VolumeMode m : {VolumeMode::BihSingle, VolumeMode::BihMulti, VolumeMode::BihIso}) {
        same([&](const VolumeRenderParams& q) {
            VolumeRenderParams r = q;
            r.mode = m;
            return render_bih_dvr_cpu(view, r, pool);
        });
    }
    same([&](const VolumeRenderParams& q) { return render_kd_dvr_cpu(gw, kd, q, pool); });
    same([&](const VolumeRenderParams& q) { return render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, q, pool); },
         false);
    same([&](const VolumeRenderParams& q) { return render_octree_iso_cpu(OctreeView{oct_words, oct.bricks}, q, pool); },
         false);
    // The octree skips nothing by a hook (its zeros are unknown) and by a float table exactly
    // what it skips by the same RGBA8 table.
    CHECK(tf_opacity_prefix(pf) == tf_opacity_prefix(p.tf));
    CHECK(tf_opacity_prefix(ph) == std::vector<std::uint32_t>{0u, 1u, 2u});
}

TEST_CASE("Bad transfer functions are refused", "[dvr][tf]") {
    ThreadPool pool(2);
    volume::DensityGrid grid = sample_grid({8, 8, 8}, vec3(1.0f), [](glm::dvec3) { return 0.5; });
    GridWords gw = GridWords::from(grid);
    VolumeRenderParams p;
    p.width = p.height = 8;
    p.tf_kind = TfKind::Rgba32f;
    p.tf_rgba32f = {1.0f, 1.0f, 1.0f};
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("whole entries of 4 floats, got 3 floats"));
    p.tf_rgba32f = {1.0f, 1.0f, std::nanf(""), 1.0f};
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("float TF entry 0 is not finite"));
    p.tf_kind = TfKind::Hook;
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("needs VolumeRenderParams::tf_hook"));
    p.tf_kind = static_cast<TfKind>(9);
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("unknown transfer function kind 9"));
    p.tf_kind = TfKind::Rgba8;
    p.tf = std::vector<std::uint32_t>(256, 0xFFFFFFFFu);
    p.opacity = static_cast<OpacityCorrection>(5);
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("unknown opacity correction 5"));
}
