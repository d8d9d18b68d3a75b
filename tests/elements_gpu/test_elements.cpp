// elements_gpu.*: the element protocol (sylva/shared/element.h) and the generic kernels
// (sylva/shared/element_kernels.h) on the host, for a user element written once (the capsule of
// examples/04_user_element_gpu) and the library's Sphere and GaussianRbf, against brute force
// over all elements.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <string>

#include "scenes.hpp"

using namespace sylva;
using namespace elements_gpu;

static_assert(Bounded<demo::Capsule> && Intersectable<demo::Capsule> && RayInteraction<demo::Capsule>);
static_assert(SharedElement<demo::Capsule> && SharedElement<Sphere> && SharedElement<GaussianRbf>);
static_assert(RayInteraction<Sphere> && RayInteraction<GaussianRbf>);

namespace {
/// Distance from p to the segment a-b (double precision reference).
double segment_distance(glm::dvec3 p, glm::dvec3 a, glm::dvec3 b) {
    glm::dvec3 ba = b - a;
    double h = glm::dot(ba, ba) > 0.0 ? std::clamp(glm::dot(p - a, ba) / glm::dot(ba, ba), 0.0, 1.0) : 0.0;
    return glm::length(p - a - h * ba);
}

template <class E, class I = BihIndex, class S>
void check_hits_against_brute_force(const S& s, std::size_t n_rays, std::uint32_t seed) {
    std::vector<Ray> rs;
    std::vector<Interval> ranges;
    rays(n_rays, seed, rs, ranges);
    std::size_t total = 0, nonempty = 0;
    for (std::size_t i = 0; i < rs.size(); ++i) {
        auto want = brute_hits<E>(s.records, s.count(), rs[i], ranges[i]);
        auto got = element_hits_cpu<E, I>(s.words, s.records, rs[i], ranges[i]);
        INFO("ray " << i << " o " << rs[i].origin.x << " " << rs[i].origin.y << " " << rs[i].origin.z << " d "
                    << rs[i].direction.x << " " << rs[i].direction.y << " " << rs[i].direction.z);
        REQUIRE(got.status == SYLVA_ITER_DONE);
        REQUIRE(got.hits.size() == want.size());
        if (!same_hits(got.hits, want)) {
            for (std::size_t k = 0; k < want.size(); ++k)
                if (got.hits[k].elem != want[k].elem || got.hits[k].t0 != want[k].t0)
                    UNSCOPED_INFO("k " << k << " got " << got.hits[k].elem << " " << got.hits[k].t0 << " " << got.hits[k].t1
                                       << " want " << want[k].elem << " " << want[k].t0 << " " << want[k].t1);
        }
        REQUIRE(same_hits(got.hits, want));
        // First hit: the kernel's own entry point.
        shared::SylvaHit first;
        std::uint32_t steps, status;
        shared::Words w{s.words.data(), s.words.size()}, e{s.records.data(), s.records.size()};
        bool found = shared::sylva_elements_first_hit<E, I>(
            w, static_cast<std::uint32_t>(s.words.size()), e, s.count(), rs[i].origin, rs[i].direction, ranges[i].t0,
            ranges[i].t1, first, steps, status);
        REQUIRE(found == !want.empty());
        if (found) REQUIRE(same_hits({first}, {want[0]}));
        // Announcing fewer hits than then asked for (sylva_hits_want) prunes, then passes again.
        {
            shared::SylvaHitIter hi;
            I idx;
            shared::sylva_hits_init<E, I>(hi, idx, w, static_cast<std::uint32_t>(s.words.size()), s.count(),
                                          rs[i].origin, rs[i].direction, ranges[i].t0, ranges[i].t1);
            shared::sylva_hits_want(hi, 2u);
            std::vector<shared::SylvaHit> all;
            shared::SylvaHit x;
            while (shared::sylva_hits_next<E, I>(hi, idx, w, e, x)) all.push_back(x);
            REQUIRE(same_hits(all, want));
        }
        total += want.size();
        nonempty += want.empty() ? 0 : 1;
    }
    CHECK(nonempty > n_rays / 3);  // the scene is actually hit
    CHECK(total > n_rays);         // and rays cross several elements
}
}  // namespace

TEST_CASE("a capsule written once: bounds hold its sampled interval, which matches a distance test", "[elements]") {
    auto cs = capsules(300, 7);
    std::vector<Ray> rs;
    std::vector<Interval> ranges;
    rays(200, 8, rs, ranges);
    std::size_t inside_samples = 0;
    for (const auto& c : cs) {
        Aabb b = bounds_of(c);
        for (std::size_t i = 0; i < rs.size(); ++i) {
            auto t = intersect_element(c, rs[i], ranges[i]);
            if (!t) continue;
            for (int k = 0; k <= 8; ++k) {
                float tt = t->t0 + (t->t1 - t->t0) * static_cast<float>(k) / 8.0f;
                glm::dvec3 p = glm::dvec3(rs[i].origin) + double(tt) * glm::dvec3(rs[i].direction);
                INFO("capsule a " << c.a.x << " r " << c.radius << " t " << tt);
                CHECK(segment_distance(p, c.a, c.b) <= c.radius + 5e-5);  // float rounding at grazing rays
                CHECK(p.x >= b.lo.x - 1e-5);
                CHECK(p.x <= b.hi.x + 1e-5);
                CHECK(p.y >= b.lo.y - 1e-5);
                CHECK(p.z <= b.hi.z + 1e-5);
                ++inside_samples;
            }
            // Just outside the interval the ray is outside the capsule (unless clipped by the range).
            float eps = 1e-3f * std::max(1.0f, t->t1 - t->t0);
            if (t->t0 > ranges[i].t0 + eps) {
                glm::dvec3 p = glm::dvec3(rs[i].origin) + double(t->t0 - eps) * glm::dvec3(rs[i].direction);
                CHECK(segment_distance(p, c.a, c.b) > c.radius * (1.0 - 1e-4));
            }
        }
    }
    CHECK(inside_samples > 100);
}

TEST_CASE("records: pack_elements round-trips and refuses a store that disagrees with its load", "[elements]") {
    auto cs = capsules(50, 3);
    auto rec = pack_elements(std::span<const demo::Capsule>(cs));
    REQUIRE(rec.size() == 50u * 12u);
    shared::Words w{rec.data(), rec.size()};
    for (std::uint32_t i = 0; i < 50; ++i) {
        demo::Capsule x;
        sylva_elem_load(w, i, x);
        CHECK(x.a == cs[i].a);
        CHECK(x.b == cs[i].b);
        CHECK(x.radius == cs[i].radius);
        CHECK(x.rgb == cs[i].rgb);
    }
    std::vector<std::uint32_t> bad_order{0u, 99u};
    CHECK_THROWS_WITH(pack_elements(std::span<const demo::Capsule>(cs), bad_order), Catch::Contains("order names element 99"));
    // Spheres keep the particle record: pack_elements == pack_particles.
    auto ss = spheres(40, 4);
    std::vector<std::uint32_t> order(40);
    for (std::uint32_t i = 0; i < 40; ++i) order[i] = 39 - i;
    CHECK(pack_elements(std::span<const Sphere>(ss), order) == pack_particles(std::span<const Sphere>(ss), order));
}

TEST_CASE("Sphere and GaussianRbf through the protocol keep their former results", "[elements]") {
    auto ss = spheres(200, 11);
    std::vector<Ray> rs;
    std::vector<Interval> ranges;
    rays(100, 12, rs, ranges);
    std::size_t checked = 0;
    for (const auto& s : ss) {
        for (std::size_t i = 0; i < rs.size(); ++i) {
            // The former Sphere::interact: alpha = clamp(A8 * exp(-kappa q)) at t_c.
            vec2 a = shared::sylva_particle_approach(s.center, s.radius, rs[i].origin, rs[i].direction);
            bool former = a.y <= 1.0f && a.x >= ranges[i].t0 && a.x <= ranges[i].t1;
            auto c = s.interact(rs[i], ranges[i]);
            REQUIRE(bool(c) == former);
            if (!c) continue;
            vec4 col = shared::sylva_unpack_rgba8(pack_rgba8(s.rgba));
            float alpha = std::clamp(col.a * std::exp(-s.kappa * a.y), 0.0f, 1.0f);
            CHECK(c->interval.t0 == a.x);
            CHECK(std::abs(c->alpha() - alpha) <= 1e-6f);
            CHECK(c->rgb == vec3(col));
            // The former chord, now sylva_elem_interval.
            float half = std::sqrt((1.0f - a.y) * s.radius * s.radius / glm::dot(rs[i].direction, rs[i].direction));
            auto t = s.intersect(rs[i], ranges[i]);
            REQUIRE(t);
            CHECK(t->t0 == std::max(ranges[i].t0, a.x - half));
            CHECK(t->t1 == std::min(ranges[i].t1, a.x + half));
            ++checked;
        }
    }
    CHECK(checked > 50);
    GaussianRbf g{{0.0f, 0.0f, 0.0f}, 0.5f, 3.0f, {1.0f, 1.0f, 1.0f, 1.0f}};
    CHECK(g.bounds().hi.x == 1.5f);
    auto c = g.interact({{-5.0f, 0.25f, 0.0f}, {1.0f, 0.0f, 0.0f}}, {});
    REQUIRE(c);
    CHECK(c->alpha() == Approx(std::exp(-0.25f * 0.25f / (2.0f * 0.25f))).epsilon(1e-5));
}

TEST_CASE("capsules: all hits in order and the first hit equal brute force over all elements", "[elements]") {
    SECTION("one capsule a leaf (trimmed)") {
        check_hits_against_brute_force<demo::Capsule>(Scene<demo::Capsule>(capsules(3000, 21)), 400, 22);
    }
    SECTION("leaves of up to 32, untrimmed") {
        check_hits_against_brute_force<demo::Capsule>(
            Scene<demo::Capsule>(capsules(3000, 23), bih::Config::for_queries()), 400, 24);
    }
    SECTION("long thin capsules overlapping many leaves") {
        check_hits_against_brute_force<demo::Capsule>(Scene<demo::Capsule>(capsules(1500, 25, 0.8f, 0.02f)), 400, 26);
    }
}

TEST_CASE("spheres and RBFs: all hits in order and the first hit equal brute force", "[elements]") {
    check_hits_against_brute_force<Sphere>(Scene<Sphere>(spheres(3000, 31)), 400, 32);
    check_hits_against_brute_force<GaussianRbf>(Scene<GaussianRbf>(rbfs(3000, 33), bih::Config::for_queries()), 400, 34);
}

TEST_CASE("the kd-tree and the octree over elements plug into the same kernels: hits == brute force",
          "[elements]") {
    check_hits_against_brute_force<demo::Capsule, KdIndex>(IndexScene<demo::Capsule, KdIndex>(capsules(3000, 35)), 400, 36);
    check_hits_against_brute_force<demo::Capsule, KdIndex>(
        IndexScene<demo::Capsule, KdIndex>(capsules(1500, 37, 0.8f, 0.02f)), 400, 38);
    check_hits_against_brute_force<Sphere, KdIndex>(IndexScene<Sphere, KdIndex>(spheres(3000, 39)), 400, 40);
    check_hits_against_brute_force<demo::Capsule, OctreeIndex>(
        IndexScene<demo::Capsule, OctreeIndex>(capsules(3000, 41)), 400, 42);
    check_hits_against_brute_force<Sphere, OctreeIndex>(IndexScene<Sphere, OctreeIndex>(spheres(3000, 43)), 400, 44);
    // Same image through all three indices (same hits in the same order: bit for bit).
    SerialExecutor exec;
    const std::uint32_t w = 40, h = 30;
    CameraFrame cam = view(w, h);
    auto cs = capsules(2000, 45);
    Scene<demo::Capsule> b(cs);
    IndexScene<demo::Capsule, KdIndex> k(cs);
    IndexScene<demo::Capsule, OctreeIndex> o(cs);
    Frame fb = render_elements_cpu<demo::Capsule>(b.words, b.records, cam, w, h, exec);
    Frame fk = render_elements_cpu<demo::Capsule, KdIndex>(k.words, k.records, cam, w, h, exec);
    Frame fo = render_elements_cpu<demo::Capsule, OctreeIndex>(o.words, o.records, cam, w, h, exec);
    CHECK(fb.rgba == fk.rgba);
    CHECK(fb.rgba == fo.rgba);
}

TEST_CASE("compositing over intervals equals brute-force compositing of interact_element", "[elements]") {
    SerialExecutor exec;
    const std::uint32_t w = 48, h = 36;
    CameraFrame cam = view(w, h);
    Scene<demo::Capsule> cs(capsules(2000, 41));
    Scene<Sphere> ss(spheres(2000, 42));
    for (float stop : {0.99f, 1.01f}) {
        Frame fc = render_elements_cpu<demo::Capsule>(cs.words, cs.records, cam, w, h, exec, {stop});
        Frame fs = render_elements_cpu<Sphere>(ss.words, ss.records, cam, w, h, exec, {stop});
        std::size_t lit = 0;
        for (std::uint32_t y = 0; y < h; ++y)
            for (std::uint32_t x = 0; x < w; ++x) {
                Ray r = cam.ray(x, y, w, h);
                std::size_t i = std::size_t{y} * w + x;
                vec4 want_c = brute_composite<demo::Capsule>(cs.records, cs.count(), r, stop);
                vec4 want_s = brute_composite<Sphere>(ss.records, ss.count(), r, stop);
                INFO("pixel " << x << " " << y << " stop " << stop);
                CHECK(fc.rgba[i] == want_c);  // same arithmetic in the same order: bit for bit
                CHECK(fs.rgba[i] == want_s);
                CHECK(fc.steps[i] != 0xFFFFFFFFu);
                lit += fc.rgba[i].a > 0.5f ? 1 : 0;
            }
        CHECK(lit > w * h / 10);
    }
}

TEST_CASE("bad input: wrong payload kind, records of the wrong size, leaves past the records", "[elements]") {
    Scene<demo::Capsule> s(capsules(100, 51));
    Ray r{{-0.5f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}};
    std::vector<std::uint32_t> short_records(s.records.begin(), s.records.end() - 1);
    CHECK_THROWS_WITH(element_hits_cpu<demo::Capsule>(s.words, short_records, r, {}), Catch::Contains("whole number"));
    std::vector<std::uint32_t> fewer(s.records.begin(), s.records.begin() + 12 * 50);
    bool error_seen = false;
    for (int i = 0; i < 40; ++i) {
        Ray q{{-0.5f, 0.025f * i, 0.5f}, {1.0f, 0.0f, 0.0f}};
        auto hits = element_hits_cpu<demo::Capsule>(s.words, fewer, q, {});
        for (auto& h : hits.hits) CHECK(h.elem < 50u);
        error_seen = error_seen || (hits.status & 255u) == SYLVA_ITER_ERROR;
    }
    CHECK(error_seen);
    auto ss = spheres(50, 52);
    bih::Tree t = bih::build(std::span<const Sphere>(ss));
    auto inline_words = bih::encode(t, std::span<const Sphere>(ss), ParticlePayload{});
    auto rec = pack_elements(std::span<const Sphere>(ss));
    CHECK_THROWS_WITH(element_hits_cpu<Sphere>(inline_words, rec, r, {}), Catch::Contains("not record ranges"));
}

TEST_CASE("more pending hits than the window holds: extra passes keep the order exact", "[elements]") {
    std::vector<demo::Capsule> cs(200);
    for (std::size_t i = 0; i < cs.size(); ++i) {  // coincident boxes: one leaf of 200
        cs[i].a = vec3(0.2f, 0.5f, 0.5f);
        cs[i].b = vec3(0.8f, 0.5f, 0.5f);
        cs[i].radius = 0.1f + 0.0005f * static_cast<float>(i % 7);
    }
    for (auto& c : cs) c.radius = 0.1f;  // identical boxes, identical intervals
    for (std::size_t i = 0; i < cs.size(); ++i) cs[i].a.x = 0.2f + 0.001f * static_cast<float>((i * 37) % 200);
    Scene<demo::Capsule> s(cs);
    Ray r{{0.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}};
    auto want = brute_hits<demo::Capsule>(s.records, s.count(), r, {});
    auto got = element_hits_cpu<demo::Capsule>(s.words, s.records, r, {});
    REQUIRE(want.size() == 200u);
    REQUIRE(got.hits.size() == 200u);
    CHECK(same_hits(got.hits, want));
    CHECK(got.passes > 1u);  // 200 pending hits, a window of 64
    CHECK(got.status == SYLVA_ITER_DONE);
}

namespace {
/// Spheres with a cluster of 150 nearly coincident ones (more pending hits than the window, so
/// rays through it take several passes) among 1,500 random ones, 64 x 48 pixels of it.
std::vector<Sphere> clustered_spheres() {
    auto ps = spheres(1500, 301);
    for (int i = 0; i < 150; ++i)
        ps.push_back(Sphere{vec3(0.5f + 0.0004f * float(i % 5), 0.5f, 0.5f), 0.12f, vec4(0.8f, 0.4f, 0.2f, 0.02f), 1.0f});
    return ps;
}
}  // namespace

TEST_CASE("compositing paused at a loop budget and resumed equals compositing in one stretch, bit for bit",
          "[elements]") {
    // What a device with a loop limit does (sylva::vk::ElementKernel::render): a ray pauses once
    // its loop iterations pass the budget and continues from its last hit in a later stretch.
    Scene<Sphere> s(clustered_spheres());
    const std::uint32_t w = 64, h = 48;
    CameraFrame cam = view(w, h);
    shared::Words words{s.words.data(), s.words.size()}, recs{s.records.data(), s.records.size()};
    auto wc = static_cast<std::uint32_t>(s.words.size());
    for (std::uint32_t budget : {1u, 40u, 300u, 3000u}) {
        std::size_t resumed = 0, lit = 0, max_stretches = 0;
        for (std::uint32_t y = 0; y < h; ++y)
            for (std::uint32_t x = 0; x < w; ++x) {
                Ray r = pixel_ray(cam, ParticleRenderConfig{}.rays, x, y, w, h);
                std::uint32_t steps, status;
                vec4 one = shared::sylva_elements_composite<Sphere, BihIndex>(words, wc, recs, s.count(), r.origin,
                                                                             r.direction, 0.0f, shared::sylva_inf(),
                                                                             0.99f, steps, status);
                shared::SylvaCompositeResume st = shared::sylva_composite_fresh();
                std::size_t stretches = 0;
                do {
                    shared::sylva_elements_composite_resume<Sphere, BihIndex>(words, wc, recs, s.count(), r.origin,
                                                                             r.direction, 0.0f, shared::sylva_inf(),
                                                                             0.99f, budget, st);
                    ++stretches;
                } while (st.status == SYLVA_ITER_RUNNING && stretches < 100000);
                INFO("budget " << budget << ", pixel " << x << "," << y << ", " << stretches << " stretches");
                REQUIRE(std::memcmp(&one, &st.rgba, sizeof one) == 0);
                CHECK(st.status == status);
                CHECK(st.steps >= steps);  // a resumed ray walks its index again
                if (stretches == 1) CHECK(st.steps == steps);
                resumed += stretches > 1;
                max_stretches = std::max(max_stretches, stretches);
                lit += one.a > 0.1f;
            }
        CHECK(lit > w * h / 4);
        CHECK(resumed > (budget <= 300u ? w * h / 10 : 0u));  // the budget made rays pause
        WARN("budget " << budget << ": " << resumed << " of " << w * h << " rays resumed, up to " << max_stretches
                       << " stretches");
    }
}

namespace {
/// A C++-only medium (no shared protocol): a box of constant extinction, member functions only.
struct FogBox {
    Aabb box;
    float sigma = 1.0f;
    [[nodiscard]] Aabb bounds() const { return box; }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval i) const { return clip(r, box, i); }
    [[nodiscard]] std::optional<Contribution> interact(const Ray& r, Interval i) const {
        auto t = clip(r, box, i);
        if (!t) return std::nullopt;
        return Contribution{*t, vec3(1.0f, 0.5f, 0.25f), sigma * (t->t1 - t->t0) * glm::length(r.direction)};
    }
};
}  // namespace

TEST_CASE("the host integrator over interact_element equals the shared kernel, and takes C++-only media",
          "[elements]") {
    const std::uint32_t w = 32, h = 24;
    CameraFrame cam = view(w, h);
    SerialExecutor exec;
    Scene<demo::Capsule> cs(capsules(1500, 101));
    Frame shared_kernel = render_elements_cpu<demo::Capsule>(cs.words, cs.records, cam, w, h, exec);
    std::vector<demo::Capsule> in_order(cs.count());
    shared::Words rec{cs.records.data(), cs.records.size()};
    for (std::uint32_t e = 0; e < cs.count(); ++e) sylva_elem_load(rec, e, in_order[e]);
    std::vector<shared::SylvaHit> scratch;
    for (std::uint32_t y = 0; y < h; ++y)
        for (std::uint32_t x = 0; x < w; ++x) {
            vec4 c = composite_interactions(cs.words, std::span<const demo::Capsule>(in_order), cam.ray(x, y, w, h),
                                            Interval{}, 0.99f, scratch);
            CHECK(c == shared_kernel.rgba[std::size_t{y} * w + x]);
        }
    // Two overlapping fog boxes: the nearer one composites first.
    std::vector<FogBox> fog{{{vec3(0.0f), vec3(1.0f)}, 2.0f}, {{vec3(0.5f), vec3(2.0f)}, 1.0f}};
    bih::Tree t = bih::build(std::span<const FogBox>(fog), bih::Config::for_queries());
    auto words = bih::encode(t, std::span<const FogBox>(fog), bih::RangePayload{});
    std::vector<FogBox> ordered{fog[t.order[0]], fog[t.order[1]]};
    Ray r{{-1.0f, 0.75f, 0.75f}, {1.0f, 0.0f, 0.0f}};
    vec4 c = composite_interactions(words, std::span<const FogBox>(ordered), r, Interval{}, 1.0f, scratch);
    float a1 = 1.0f - std::exp(-2.0f), a2 = 1.0f - std::exp(-1.5f);
    CHECK(c.a == Approx(a1 + (1.0f - a1) * a2).epsilon(1e-6));
    CHECK(c.r == Approx(a1 + (1.0f - a1) * a2).epsilon(1e-6));
}
