// conformance.*: the element conformance kit (sylva/testing/conformance.hpp) on the library's own
// element types, and on deliberately broken elements, where it must fail and name the ray.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>

#include "sylva/elements/rbf.hpp"
#include "sylva/elements/sphere.hpp"
#include "sylva/elements/voxel.hpp"
#include "sylva/testing/conformance.hpp"

using sylva::Aabb;
using sylva::Interval;
using sylva::Ray;
using sylva::vec3;
using sylva::vec4;
using sylva::testing::ConformanceConfig;
using sylva::testing::Report;
using sylva::testing::Rng;

namespace {

sylva::Sphere random_sphere(Rng& rng) {
    sylva::Sphere s;
    s.center = rng.in_box({vec3(-5.0f), vec3(5.0f)});
    s.radius = rng.uniform(0.02f, 0.5f);
    s.rgba = vec4(rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(0.2f, 1.0f));
    s.kappa = rng.uniform(0.5f, 4.0f);
    return s;
}

/// Fewer rays and instances than the defaults: these run once per broken element as well.
ConformanceConfig quick() {
    ConformanceConfig cfg;
    cfg.element_count = 600;
    cfg.bounds_instances = 80;
    cfg.structure_rays = 600;
    return cfg;
}

/// Whether some kept mismatch comes from `check` (a prefix such as "bih." or "bounds").
bool has_check(const Report& r, const std::string& check) {
    for (const auto& m : r.mismatches)
        if (m.check.rfind(check, 0) == 0) return true;
    return false;
}

// ---- deliberately broken elements --------------------------------------------------------

/// Bounds 20 % too small around a correct sphere.
struct BoundsTooSmall {
    sylva::Sphere s;
    [[nodiscard]] Aabb bounds() const { return {s.center - vec3(0.8f * s.radius), s.center + vec3(0.8f * s.radius)}; }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval i) const { return s.intersect(r, i); }
};

/// A correct box, but an interval that runs on past the sphere's exit (by one radius, scaled to t).
struct IntersectTooLong {
    sylva::Sphere s;
    [[nodiscard]] Aabb bounds() const { return s.bounds(); }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval i) const {
        auto t = s.intersect(r, Interval{-INFINITY, INFINITY});
        if (!t) return t;
        const Interval longer{std::max(i.t0, t->t0), std::min(i.t1, t->t1 + s.radius / glm::length(r.direction))};
        if (longer.empty()) return std::nullopt;
        return longer;
    }
};

/// Correct geometry, but the query range is ignored (the structures pass leaf ranges).
struct IgnoresRange {
    sylva::Sphere s;
    [[nodiscard]] Aabb bounds() const { return s.bounds(); }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval) const {
        return s.intersect(r, Interval{-INFINITY, INFINITY});
    }
};

/// A ball of constant extinction (a C++-only RayInteraction): depth sigma * path length, or, when
/// `squared`, sigma * length^2 (wrong: not additive over a split interval).
struct FogBall {
    sylva::Sphere s;
    float sigma = 2.0f;
    bool squared = false;
    [[nodiscard]] Aabb bounds() const { return s.bounds(); }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval i) const { return s.intersect(r, i); }
    [[nodiscard]] std::optional<sylva::Contribution> interact(const Ray& r, Interval i) const {
        auto t = s.intersect(r, i);
        if (!t) return std::nullopt;
        const float length = (t->t1 - t->t0) * glm::length(r.direction);
        return sylva::Contribution{*t, vec3(1.0f), squared ? sigma * length * length : sigma * length};
    }
};

}  // namespace

TEST_CASE("spheres conform: bounds, BIH, element octree and kd-tree queries, order, refit", "[conformance]") {
    const Report r = sylva::testing::check_element_type<sylva::Sphere>(random_sphere);
    INFO(r);
    CHECK(r.ok());
    CHECK(r.checks > 60000);  // every part ran: bounds, three structures, refit, coincident copies
    const std::string text = sylva::testing::to_string(r);
    for (const char* part : {"bounds:", "bih:", "octree:", "kdtree:", "kdtree.refit:", "coincident bih:"})
        CHECK(text.find(part) != std::string::npos);
}

TEST_CASE("Gaussian RBFs conform", "[conformance]") {
    const Report r = sylva::testing::check_element_type<sylva::GaussianRbf>([](Rng& rng) {
        sylva::GaussianRbf g;
        g.center = rng.in_box({vec3(0.0f), vec3(20.0f)});
        g.sigma = rng.uniform(0.01f, 0.3f);
        g.truncation = rng.uniform(1.0f, 4.0f);
        return g;
    }, quick());
    INFO(r);
    CHECK(r.ok());
}

TEST_CASE("voxel cuboids conform as boxes (Bounded only: every box a ray crosses is reported)", "[conformance]") {
    const Report r = sylva::testing::check_element_type<sylva::VoxelCuboid>([](std::size_t i, Rng& rng) {
        // A 16^3 lattice of unit voxels with a random gap, as a volume's occupied cells.
        const vec3 cell(float(i % 16), float((i / 16) % 16), float((i / 256) % 16));
        sylva::VoxelCuboid v;
        v.box = {cell, cell + vec3(1.0f - 0.5f * rng.uniform())};
        v.density = rng.uniform();
        return v;
    }, quick());
    INFO(r);
    CHECK(r.ok());
}

TEST_CASE("the kit fails on bounds that are too small, naming the ray", "[conformance][broken]") {
    const Report r = sylva::testing::check_element_type<BoundsTooSmall>(
        [](Rng& rng) { return BoundsTooSmall{random_sphere(rng)}; }, quick());
    CHECK_FALSE(r.ok());
    CHECK(has_check(r, "bounds"));
    std::ostringstream text;
    text << r;
    INFO(text.str());
    CHECK(text.str().find("outside bounds()") != std::string::npos);
    CHECK(text.str().find("ray origin (") != std::string::npos);
    // The structures trust the boxes: they lose hits brute force finds.
    const Report structures = sylva::testing::check_structures<BoundsTooSmall>(
        [] {
            std::vector<BoundsTooSmall> v;
            Rng rng(7);
            for (int i = 0; i < 600; ++i) v.push_back({random_sphere(rng)});
            return v;
        }(),
        quick());
    CHECK_FALSE(structures.ok());
    CHECK(has_check(structures, "bih."));
}

TEST_CASE("the kit fails on an intersect that runs past the element", "[conformance][broken]") {
    const Report r = sylva::testing::check_element_type<IntersectTooLong>(
        [](Rng& rng) { return IntersectTooLong{random_sphere(rng)}; }, quick());
    CHECK_FALSE(r.ok());
    CHECK(has_check(r, "bounds"));
    INFO(r);
    CHECK(sylva::testing::to_string(r).find("intersect too long") != std::string::npos);
}

TEST_CASE("the kit fails on an intersect that ignores the range", "[conformance][broken]") {
    ConformanceConfig cfg = quick();
    const Report bounds = sylva::testing::check_bounds<IgnoresRange>(
        [] {
            std::vector<IgnoresRange> v;
            Rng rng(3);
            for (int i = 0; i < 80; ++i) v.push_back({random_sphere(rng)});
            return v;
        }(),
        cfg);
    CHECK_FALSE(bounds.ok());
    CHECK(has_check(bounds, "range"));
    INFO(bounds);
    CHECK(sylva::testing::to_string(bounds).find("clipped to it is") != std::string::npos);
}

TEST_CASE("host against device: equal results pass, a wrong first hit or count fails with its ray",
          "[conformance][device]") {
    Rng rng(11);
    std::vector<sylva::Sphere> spheres;
    for (int i = 0; i < 400; ++i) spheres.push_back(random_sphere(rng));
    std::vector<Ray> rays;
    for (int i = 0; i < 500; ++i) {
        const vec3 target = rng.in_box({vec3(-5.0f), vec3(5.0f)});
        const vec3 d = rng.direction();
        rays.push_back({target - 20.0f * d, d});
    }
    const std::span<const sylva::Sphere> view(spheres);
    const auto host = sylva::testing::host_ray_hits(view, std::span<const Ray>(rays));
    const Report same = sylva::testing::compare_ray_hits(view, std::span<const Ray>(rays), host, host, 0.0f);
    INFO(same);
    CHECK(same.ok());

    auto device = host;
    std::size_t changed = 0;
    for (std::size_t i = 0; i < device.size() && changed < 3; ++i) {
        if (device[i].count == 0) continue;
        device[i].t.t0 *= 1.01f;  // beyond the tolerance
        ++changed;
    }
    REQUIRE(changed == 3);
    device[0].count += 1;
    const Report wrong = sylva::testing::compare_ray_hits(view, std::span<const Ray>(rays), host, device, 1e-5f);
    CHECK_FALSE(wrong.ok());
    CHECK(wrong.failures >= 3);
    CHECK(has_check(wrong, "device"));
    // Within the tolerance passes.
    auto close = host;
    for (auto& h : close) h.t.t1 = std::nextafter(h.t.t1, INFINITY);
    CHECK(sylva::testing::compare_ray_hits(view, std::span<const Ray>(rays), host, close, 1e-5f).ok());
}

TEST_CASE("media: constant extinction conforms, a depth that is not additive over a split fails",
          "[conformance][broken]") {
    const Report good = sylva::testing::check_element_type<FogBall>(
        [](Rng& rng) { return FogBall{random_sphere(rng), rng.uniform(0.5f, 5.0f), false}; }, quick());
    INFO(good);
    CHECK(good.ok());
    CHECK(sylva::testing::to_string(good).find("medium:") != std::string::npos);

    const Report bad = sylva::testing::check_element_type<FogBall>(
        [](Rng& rng) { return FogBall{random_sphere(rng), rng.uniform(0.5f, 5.0f), true}; }, quick());
    CHECK_FALSE(bad.ok());
    CHECK(has_check(bad, "medium"));
    INFO(bad);
    CHECK(sylva::testing::to_string(bad).find("not additive") != std::string::npos);
}
