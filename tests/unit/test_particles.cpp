// Particle weight, elements and the compositing integrator against independent references.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/elements/rbf.hpp>
#include <sylva/elements/sphere.hpp>
#include <sylva/io/particles.hpp>
#include <sylva/render/particles.hpp>

#include "generators.hpp"

using namespace sylva;

TEST_CASE("sphere weight follows exp(-kappa (d/r)^2) and vanishes past r", "[particles]") {
    Sphere s{{0.0f, 0.0f, 5.0f}, 2.0f, {1.0f, 1.0f, 1.0f, 1.0f}, 3.0f};
    for (float d : {0.0f, 0.5f, 1.0f, 1.9f}) {
        auto c = s.interact({{d, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}}, {});
        REQUIRE(c);
        CHECK(c->interval.t0 == Approx(5.0f));
        CHECK(c->alpha() == Approx(std::exp(-3.0f * (d / 2.0f) * (d / 2.0f))).epsilon(1e-5));
    }
    CHECK_FALSE(s.interact({{2.01f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}}, {}));
    CHECK_FALSE(s.interact({{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}}, {0.0f, 4.0f}));  // beyond range
    auto hit = s.intersect({{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.0f}}, {});
    REQUIRE(hit);
    CHECK(hit->t0 == Approx(1.5f));
    CHECK(hit->t1 == Approx(3.5f));
}

TEST_CASE("a truncated Gaussian RBF is exp(-d^2 / 2 sigma^2) up to k sigma", "[particles]") {
    GaussianRbf g{{0.0f, 0.0f, 0.0f}, 0.5f, 3.0f, {1.0f, 1.0f, 1.0f, 1.0f}};
    CHECK(g.bounds().hi.x == Approx(1.5f));
    for (float d : {0.0f, 0.25f, 0.5f, 1.0f, 1.49f}) {
        auto c = g.interact({{-5.0f, d, 0.0f}, {1.0f, 0.0f, 0.0f}}, {});
        REQUIRE(c);
        CHECK(c->alpha() == Approx(std::exp(-d * d / (2.0f * 0.25f))).epsilon(1e-5));
    }
    CHECK_FALSE(g.interact({{-5.0f, 1.51f, 0.0f}, {1.0f, 0.0f, 0.0f}}, {}));
}

namespace {
/// Reference: every particle's contribution, sorted by t, composited front to back (no tree).
vec4 reference_composite(const std::vector<Sphere>& ps, const Ray& r, float stop) {
    std::vector<Contribution> cs;
    for (const auto& p : ps)
        if (auto c = p.interact(r, {})) cs.push_back(*c);
    std::stable_sort(cs.begin(), cs.end(), [](auto& a, auto& b) { return a.interval.t0 < b.interval.t0; });
    vec3 rgb{0.0f};
    float alpha = 0.0f;
    for (auto& c : cs) {
        if (alpha >= stop) break;
        float k = (1.0f - alpha) * c.alpha();
        rgb += k * c.rgb;
        alpha += k;
    }
    return {rgb, alpha};
}
}  // namespace

TEST_CASE("BIH particle integrator equals sorted brute-force compositing", "[particles]") {
    // Well separated particles: no overlap, so leaf order is exact and the results must agree.
    std::vector<Sphere> ps;
    std::mt19937 rng(51);
    std::uniform_real_distribution<float> c(0.1f, 0.9f);
    for (int z = 0; z < 8; ++z)
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x)
                ps.push_back({{x + 0.5f, y + 0.5f, z + 0.5f}, 0.3f + 0.15f * c(rng), {c(rng), c(rng), c(rng), c(rng)}, 1.5f});
    std::span<const Sphere> es(ps);
    bih::Tree t = bih::build(es);
    auto range_words = bih::encode(t, es, bih::RangePayload{}, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 2});
    auto inline_words = bih::encode(t, es, ParticlePayload{}, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2});
    auto records = pack_particles(es, t.order);
    shared::Words rw{range_words.data(), range_words.size()}, iw{inline_words.data(), inline_words.size()};
    shared::Words el{records.data(), records.size()}, none{};
    double worst_range = 0.0;
    int inline_off = 0, samples = 0;
    int nonzero = 0;
    for (const Ray& r : testing::random_rays(5000, {vec3(0.0f), vec3(8.0f)}, 52)) {
        for (float stop : {0.99f, 2.0f}) {
            vec4 want = reference_composite(ps, r, stop);
            std::uint32_t steps, status;
            vec4 a = shared::sylva_render_particles(rw, static_cast<std::uint32_t>(range_words.size()), el, r.origin,
                                                    r.direction, 0.0f, 1e30f, stop, steps, status);
            vec4 b = shared::sylva_render_particles(iw, static_cast<std::uint32_t>(inline_words.size()), none, r.origin,
                                                    r.direction, 0.0f, 1e30f, stop, steps, status);
            CHECK(status != SYLVA_ITER_ERROR);  // RUNNING when the ray terminated early
            nonzero += want.a > 0.0f;
            float off = 0.0f;
            for (int k = 0; k < 4; ++k) {
                worst_range = std::max(worst_range, double(std::abs(a[k] - want[k])));
                off = std::max(off, std::abs(b[k] - want[k]));
            }
            inline_off += off > 1e-3f;
            ++samples;
        }
    }
    CHECK(nonzero > 1000);
    CHECK(worst_range < 1e-5);
    // Inline leaves quantise the particle's box to 1/32768 of the scene. The kernel is cut off
    // at r, so rays grazing the rim within that step flip in or out; all others agree closely.
    CHECK(inline_off < samples / 200);
}

namespace {
/// Range payloads that claim a different kind (a LoD or voxel encoding) or start 2^29 records
/// further on (where e * 8 wraps around 32 bits to the real records).
template <std::uint32_t Kind, std::uint32_t Offset>
struct ShiftedRange {
    static constexpr std::uint32_t kind = Kind;
    template <Bounded E>
    [[nodiscard]] std::uint64_t encode(std::span<const E> leaf, std::uint32_t first) const {
        return bih::RangePayload{}.encode(leaf, first + Offset);
    }
};

struct ParticleScene {
    std::vector<Sphere> ps;
    bih::Tree t;
    std::vector<std::uint32_t> records;
    ParticleScene() {
        for (int x = 0; x < 4; ++x)
            for (int y = 0; y < 4; ++y) ps.push_back({{x + 0.5f, y + 0.5f, 0.5f}, 0.45f, {1.0f, 0.5f, 0.25f, 0.8f}, 1.0f});
        t = bih::build(std::span<const Sphere>(ps));
        records = pack_particles(std::span<const Sphere>(ps), t.order);
    }
    template <class P>
    std::vector<std::uint32_t> words(const P& p) const {
        return bih::encode(t, std::span<const Sphere>(ps), p, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 2});
    }
};
}  // namespace

TEST_CASE("the particle integrators refuse an encoding whose payload kind is not a particle kind",
          "[particles][payload-kind]") {
    using Catch::Matchers::Contains;
    ParticleScene s;
    CameraFrame cam = Camera::framing(s.t.bounds).frame(8, 8);
    SerialExecutor serial;
    auto voxel = s.words(ShiftedRange<SYLVA_PAYLOAD_VOXEL, 0>{});
    CHECK_THROWS_WITH(render_particles_cpu(voxel, s.records, cam, 8, 8, serial),
                      Contains("payload kind 2") && Contains("particle"));
    auto user = s.words(ShiftedRange<200u, 0>{});
    CHECK_THROWS_WITH(render_particles_cpu(user, s.records, cam, 8, 8, serial), Contains("payload kind 200"));
    // The shared integrator itself (what the shader runs) ends with an error, drawing nothing.
    shared::Words w{voxel.data(), voxel.size()}, el{s.records.data(), s.records.size()};
    std::uint32_t steps = 0, status = 0;
    vec4 c = shared::sylva_render_particles(w, static_cast<std::uint32_t>(voxel.size()), el, {0.5f, 0.5f, -5.0f},
                                            {0.0f, 0.0f, 1.0f}, 0.0f, 1e30f, 0.99f, steps, status);
    CHECK(status == SYLVA_ITER_ERROR);
    CHECK(c == vec4(0.0f));
    // The genuine kinds still render.
    CHECK_NOTHROW(render_particles_cpu(s.words(bih::RangePayload{}), s.records, cam, 8, 8, serial));
    CHECK_NOTHROW(render_particles_cpu(s.words(ParticlePayload{}), {}, cam, 8, 8, serial));
}

TEST_CASE("range leaves at or past 2^29 records are an error, not an index wrapped around 32 bits",
          "[particles][index-math]") {
    ParticleScene s;
    auto good = s.words(bih::RangePayload{});
    auto far = s.words(ShiftedRange<SYLVA_PAYLOAD_RANGE, (1u << 29)>{});  // e * 8 wraps to the real records
    shared::Words gw{good.data(), good.size()}, fw{far.data(), far.size()}, el{s.records.data(), s.records.size()};
    Ray r{{0.5f, 0.5f, -5.0f}, {0.0f, 0.0f, 1.0f}};
    std::uint32_t steps = 0, status = 0;
    vec4 want = shared::sylva_render_particles(gw, static_cast<std::uint32_t>(good.size()), el, r.origin, r.direction,
                                               0.0f, 1e30f, 0.99f, steps, status);
    REQUIRE(status != SYLVA_ITER_ERROR);
    REQUIRE(want.a > 0.1f);
    vec4 got = shared::sylva_render_particles(fw, static_cast<std::uint32_t>(far.size()), el, r.origin, r.direction,
                                              0.0f, 1e30f, 0.99f, steps, status);
    CHECK(status == SYLVA_ITER_ERROR);
    CHECK(got.a == 0.0f);
}

TEST_CASE("particles with large finite coordinates get finite radii and build; beyond float32's reach they are refused for it",
          "[particles][io]") {
    using Catch::Matchers::Contains;
    for (float scale : {7e12f, 1e15f, 1e19f, 1e30f}) {
        INFO("scale " << scale);
        std::vector<vec3> pts;
        for (int i = 0; i < 64; ++i)
            pts.push_back(vec3(float(i % 4), float((i / 4) % 4), float(i / 16)) * (scale / 4.0f));
        std::vector<Sphere> ps = io::spheres_from_points(pts);
        REQUIRE(ps.size() == pts.size());
        CHECK(std::isfinite(ps[0].radius));
        CHECK(ps[0].radius == Approx(0.25f * 0.75f * scale / 4.0f).epsilon(1e-4));  // a quarter of the mean spacing
        for (const Sphere& s : ps)
            for (int k = 0; k < 4; ++k) REQUIRE(std::isfinite(s.rgba[k]));
        CHECK_NOTHROW(bih::build(std::span<const Sphere>(ps)));
    }
    // Points spanning the whole float32 range: their spheres would reach past it.
    std::vector<vec3> edge{vec3(-3.4e38f), vec3(3.4e38f), vec3(0.0f)};
    CHECK_THROWS_WITH(io::spheres_from_points(edge), Contains("particle") && Contains("float32 range") &&
                                                         !Contains("NaN"));
}

namespace {
std::string write_points(const std::filesystem::path& dir, const std::string& name, std::size_t floats) {
    std::vector<float> v(floats, 1.0f);
    std::filesystem::path p = dir / name;
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * 4));
    return p.string();
}
}  // namespace

TEST_CASE("particle file names: the count and layout they state are checked, never skipped", "[particles][io]") {
    using Catch::Matchers::Contains;
    std::filesystem::path dir = std::filesystem::temp_directory_path() / ("sylva_points_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    CHECK(io::read_points(write_points(dir, "ok_10x3_float32.raw", 30)).size() == 10);
    CHECK(io::read_points(write_points(dir, "plain.raw", 30)).size() == 10);  // the name states nothing
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "bad_11x3_float32.raw", 30)), Contains("its name says 11"));
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "zero_0x3_float32.raw", 30)), Contains("its name says 0"));
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "huge_1000000000000000000x3_float32.raw", 30)),
                      Contains("its name says 1000000000000000000"));
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "huge_99999999999999999999x3_float32.raw", 30)),
                      Contains("99999999999999999999"));
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "four_12x4_float32.raw", 48)),  // 192 bytes: 16 whole triples
                      Contains("12x4_float32") && Contains("float32 xyz"));
    CHECK_THROWS_WITH(io::read_points(write_points(dir, "bytes_10x3_uint8.raw", 30)),
                      Contains("10x3_uint8") && Contains("float32 xyz"));
    std::filesystem::remove_all(dir);
}
