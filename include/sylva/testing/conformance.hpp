// sylva/testing/conformance.hpp -- a conformance kit for element types: does a user's element
// (or one of the library's) keep the promises the structures rely on, and do the structures
// answer its queries exactly?
//
// Framework-neutral: every check returns a Report (ok(), the mismatches with the ray that shows
// each, printable with operator<<), so it works from any test framework or a plain main:
//
//   auto report = sylva::testing::check_element_type<Capsule>(make_capsule);   // E(Rng&)
//   Catch2:        INFO(report); CHECK(report.ok());
//   GoogleTest:    EXPECT_TRUE(report.ok()) << report;
//   plain main:    if (!report.ok()) { std::cerr << report; return 1; }
//
// What is checked (each check is also callable on its own):
//  * bounds (check_bounds): rays aimed at and around each instance; every point of every
//    interval intersect() returns (entry, exit, and points between) lies in bounds(); the
//    interval is ordered, finite and inside the query range; a sub-range gives the full-range
//    interval clipped to it (intersect must honour `range` exactly: the structures pass leaf
//    ranges and rely on it).
//  * structures (check_structures): first_hit and all_hits of the BIH (RangePayload encoding),
//    the element octree and the element kd-tree, each equal to brute force (bih::brute_force_hits)
//    on random rays, axis-parallel rays, rays starting inside the scene and limited ranges; each
//    again after its update over moved instances: bih::refit, kdtree::refit_elements,
//    octree::refit_elements (a tree built with a refit margin) and octree::rebuild_elements.
//  * medium (check_medium, for RayInteraction types): optical depth >= 0, finite colour, the
//    contribution inside intersect's interval, and additive over a split of the interval.
//  * ordering (inside check_structures): all_hits is sorted by bih::hit_before, names no element
//    twice, and first_hit is its first entry.
//  * host against a device (compare_ray_hits): per ray, the first hit (element, entry, exit)
//    and the number of elements hit, against what a device kernel returned for the same rays
//    (host_ray_hits gives the host side; a Vulkan run fills the device side). Entry and exit
//    compare within a relative tolerance: Vulkan does not require division, sqrt or exp to be
//    correctly rounded (docs/DESIGN.md, parity rules); where the host's two nearest entries lie
//    within that tolerance either element is accepted.
//
// Elements that are only Bounded (no intersect, e.g. VoxelCuboid) are checked as their boxes:
// the structures must then report every element whose box the ray crosses.
//
// Everything is deterministic: the generator gets a seeded Rng (a 64-bit LCG, the same sequence
// on every platform), and the rays come from the same seed.
#ifndef SYLVA_TESTING_CONFORMANCE_HPP
#define SYLVA_TESTING_CONFORMANCE_HPP

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "sylva/bih/build.hpp"
#include "sylva/bih/encode.hpp"
#include "sylva/bih/payload.hpp"
#include "sylva/bih/query.hpp"
#include "sylva/bih/refit.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/core/ray.hpp"
#include "sylva/kdtree/elements.hpp"
#include "sylva/kdtree/elements_encode.hpp"
#include "sylva/octree/elements.hpp"
#include "sylva/octree/elements_encode.hpp"
#include "sylva/octree/elements_refit.hpp"

namespace sylva::testing {

/// A small deterministic random source for generators and rays (Knuth's MMIX LCG, top bits).
class Rng {
public:
    explicit Rng(std::uint64_t seed) : state_(seed * 2862933555777941757ull + 3037000493ull) {}
    /// 32 random bits.
    std::uint32_t bits() {
        state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<std::uint32_t>(state_ >> 32);
    }
    /// Uniform in [0, 1).
    float uniform() { return static_cast<float>(bits() >> 8) * (1.0f / 16777216.0f); }
    /// Uniform in [lo, hi).
    float uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }
    /// Uniform in the box.
    vec3 in_box(const Aabb& box) {
        return vec3(uniform(box.lo.x, box.hi.x), uniform(box.lo.y, box.hi.y), uniform(box.lo.z, box.hi.z));
    }
    /// A direction uniform on the unit sphere.
    vec3 direction() {
        for (;;) {
            vec3 v(uniform(-1.0f, 1.0f), uniform(-1.0f, 1.0f), uniform(-1.0f, 1.0f));
            float l = glm::dot(v, v);
            if (l > 1e-4f && l <= 1.0f) return v / std::sqrt(l);
        }
    }

private:
    std::uint64_t state_;
};

/// Settings of the checks. Defaults take well under a second per element type on one core.
struct ConformanceConfig {
    std::uint64_t seed = 1;                  ///< seeds the generator and the rays
    std::size_t element_count = 4000;        ///< instances per scene for the structure checks
    std::size_t bounds_instances = 400;      ///< instances the bounds check probes
    std::size_t rays_per_instance = 64;      ///< bounds-check rays per instance
    std::size_t structure_rays = 4000;       ///< rays per structure and scene
    std::size_t coincident_copies = 24;      ///< size of the scene of one instance repeated (ties)
    /// A point of an interval may lie this far outside bounds() (relative to the box's size and
    /// position): the rounding of o + t d, not a real overshoot.
    float bounds_slack = 1e-4f;
    bool check_bih = true;
    bool check_octree = true;
    bool check_kdtree = true;      ///< kd-tree queries, and the kd-tree after refit_elements
    /// The structures again after their update onto moved instances (check_element_type: a
    /// second generated scene): BIH refit, kd-tree refit, element octree refit and rebuild.
    bool check_updates = true;
    std::size_t max_reports = 8;   ///< mismatches kept per report (all are counted)
};

/// One failed expectation, with the ray that shows it.
struct Mismatch {
    std::string check;  ///< which check: "bounds", "range", "bih.all_hits", "octree.first_hit", ...
    std::string what;   ///< what was expected and what came
    Ray ray;
    Interval range;
};

/// The outcome of one or more checks.
struct Report {
    std::size_t checks = 0;             ///< expectations evaluated
    std::size_t failures = 0;           ///< expectations that failed (all of them, kept or not)
    std::vector<Mismatch> mismatches;   ///< the first few failures, with their rays
    std::vector<std::string> notes;     ///< what ran (one line per check), for the log
    std::size_t max_reports = 8;

    [[nodiscard]] bool ok() const { return failures == 0 && checks > 0; }

    /// Counts one expectation; keeps the failure (up to max_reports) when `passed` is false;
    /// what() describes it (called only for kept failures).
    template <class What>
    void expect(bool passed, const char* check, const Ray& ray, Interval range, What&& what) {
        ++checks;
        if (passed) return;
        ++failures;
        if (kept(check) < (max_reports + 2) / 3 && mismatches.size() < max_reports)
            mismatches.push_back({check, what(), ray, range});
    }
    /// How many kept mismatches come from `check` (each check keeps a third of max_reports, so
    /// that one failing check does not hide the others).
    [[nodiscard]] std::size_t kept(const std::string& check) const {
        return static_cast<std::size_t>(
            std::count_if(mismatches.begin(), mismatches.end(), [&](const Mismatch& m) { return m.check == check; }));
    }
    /// Adds another report's counts and mismatches.
    void merge(const Report& other) {
        checks += other.checks;
        failures += other.failures;
        for (const Mismatch& m : other.mismatches)
            if (kept(m.check) < (max_reports + 2) / 3 && mismatches.size() < max_reports) mismatches.push_back(m);
        notes.insert(notes.end(), other.notes.begin(), other.notes.end());
    }
};

/// "(x, y, z)" with 9 significant digits: enough to rebuild the float exactly.
inline std::string format_vec3(const vec3& v) {
    char text[96];
    std::snprintf(text, sizeof text, "(%.9g, %.9g, %.9g)", double(v.x), double(v.y), double(v.z));
    return text;
}

/// "[t0, t1]" with 9 significant digits.
inline std::string format_interval(const Interval& t) {
    char text[64];
    std::snprintf(text, sizeof text, "[%.9g, %.9g]", double(t.t0), double(t.t1));
    return text;
}

/// A list of hits: "e12 [0.1, 0.2], e7 [...]" (the first 6, then how many more).
inline std::string format_hits(std::span<const bih::ElementHit> hits) {
    if (hits.empty()) return "no hits";
    std::string text;
    for (std::size_t i = 0; i < hits.size() && i < 6; ++i) {
        // Appended piece by piece: "e" + std::string&& trips GCC 12's -Wrestrict false positive
        // (GCC bug 105329) where this function is inlined.
        if (i > 0) text += ", ";
        text += 'e';
        text += std::to_string(hits[i].element);
        text += ' ';
        text += format_interval(hits[i].t);
    }
    if (hits.size() > 6) text += ", ... (" + std::to_string(hits.size()) + " in all)";
    return text;
}

inline std::ostream& operator<<(std::ostream& out, const Mismatch& m) {
    return out << m.check << ": " << m.what << "\n    ray origin " << format_vec3(m.ray.origin) << " direction "
               << format_vec3(m.ray.direction) << " range " << format_interval(m.range);
}

inline std::ostream& operator<<(std::ostream& out, const Report& r) {
    out << "sylva conformance: " << r.failures << " of " << r.checks << " expectations failed";
    for (const std::string& note : r.notes) out << "\n  " << note;
    for (const Mismatch& m : r.mismatches) out << "\n  " << m;
    if (r.failures > r.mismatches.size())
        out << "\n  ... " << (r.failures - r.mismatches.size()) << " more failures not shown";
    return out << "\n";
}

/// The whole report as text (for frameworks that take strings).
inline std::string to_string(const Report& r) {
    std::string text = "sylva conformance: " + std::to_string(r.failures) + " of " + std::to_string(r.checks) +
                       " expectations failed";
    for (const std::string& note : r.notes) text += "\n  " + note;
    for (const Mismatch& m : r.mismatches) {
        text += "\n  " + m.check + ": " + m.what + "\n    ray origin " + format_vec3(m.ray.origin) + " direction " +
                format_vec3(m.ray.direction) + " range " + format_interval(m.range);
    }
    if (r.failures > r.mismatches.size())
        text += "\n  ... " + std::to_string(r.failures - r.mismatches.size()) + " more failures not shown";
    return text + "\n";
}

/// A Bounded element without intersect(), checked as its box (the exact interval of a box).
template <Bounded E>
struct AsBox {
    E element;
    [[nodiscard]] Aabb bounds() const { return bounds_of(element); }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const {
        return clip(ray, bounds(), range);
    }
};

/// The element type the checks run on: E itself when Intersectable, else AsBox<E>.
template <Bounded E>
using Checked = std::conditional_t<Intersectable<E>, E, AsBox<E>>;

namespace detail {

/// Calls the generator as gen(rng) or gen(index, rng).
template <class E, class Gen>
E generate_one(Gen& gen, std::size_t index, Rng& rng) {
    if constexpr (std::is_invocable_r_v<E, Gen&, std::size_t, Rng&>) return gen(index, rng);
    else return gen(rng);
}

template <class E, class Gen>
std::vector<Checked<E>> generate(Gen& gen, std::size_t count, Rng& rng) {
    std::vector<Checked<E>> out;
    out.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
        if constexpr (Intersectable<E>) out.push_back(generate_one<E>(gen, i, rng));
        else out.push_back(AsBox<E>{generate_one<E>(gen, i, rng)});
    }
    return out;
}

/// How far outside `box` a point may lie (rounding of o + t d), per the config's slack.
inline float slack_of(const Aabb& box, const Ray& ray, float t, float relative) {
    float scale = std::max(glm::length(box.extent()), 1e-30f);
    float size = std::max({std::fabs(box.lo.x), std::fabs(box.lo.y), std::fabs(box.lo.z), std::fabs(box.hi.x),
                           std::fabs(box.hi.y), std::fabs(box.hi.z), glm::length(ray.origin),
                           std::fabs(t) * glm::length(ray.direction)});
    return relative * std::max(scale, size * 1e-2f);
}

inline bool inside_with_slack(const Aabb& box, const vec3& p, float slack) {
    for (int a = 0; a < 3; ++a)
        if (!(p[a] >= box.lo[a] - slack && p[a] <= box.hi[a] + slack)) return false;
    return true;
}

/// Rays aimed at an instance: from outside its box (distance 1-3 box diagonals) at points in
/// the box grown to twice its size (so that parts of the element outside a too-small box are
/// crossed), some axis-parallel, some starting inside.
inline std::vector<Ray> rays_at(const Aabb& box, std::size_t count, Rng& rng) {
    std::vector<Ray> rays;
    vec3 c = box.center();
    vec3 half = glm::max(box.extent() * 0.5f, vec3(1e-6f));
    float diagonal = 2.0f * glm::length(half);
    Aabb wide{c - 2.0f * half, c + 2.0f * half};
    for (std::size_t i = 0; i < count; ++i) {
        vec3 target = rng.in_box(wide);
        if (i % 8 == 7) {  // axis-parallel through the target
            vec3 d(0.0f);
            d[static_cast<int>(rng.bits() % 3u)] = (rng.bits() & 1u) != 0u ? 1.0f : -1.0f;
            rays.push_back({target - d * (diagonal * 2.0f), d});
        } else if (i % 8 == 6) {  // starting inside the box
            rays.push_back({rng.in_box(box), rng.direction()});
        } else {
            vec3 d = rng.direction();
            rays.push_back({target - d * (diagonal * rng.uniform(1.0f, 3.0f)), d * rng.uniform(0.5f, 2.0f)});
        }
    }
    return rays;
}

}  // namespace detail

/// Bounds against sampled intersections, and honouring of `range` (see the top of the file).
template <Intersectable E>
Report check_bounds(std::span<const E> instances, const ConformanceConfig& cfg = {}) {
    Report r;
    r.max_reports = cfg.max_reports;
    Rng rng(cfg.seed ^ 0xB0B0B0B0ull);
    const Interval full{-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
    std::size_t hits = 0;
    for (std::size_t k = 0; k < instances.size(); ++k) {
        const E& e = instances[k];
        const Aabb box = bounds_of(e);
        const std::string name = "instance " + std::to_string(k) + " with bounds " + format_vec3(box.lo) + " - " +
                                 format_vec3(box.hi);
        r.expect(!box.empty() && box.finite(), "bounds", Ray{}, full, [&] { return name + " is empty or not finite"; });
        if (box.empty() || !box.finite()) continue;
        for (const Ray& ray : detail::rays_at(box, cfg.rays_per_instance, rng)) {
            const std::optional<Interval> t = intersect_element(e, ray, full);
            if (!t) continue;
            ++hits;
            const bool ordered = t->t0 <= t->t1 && std::isfinite(t->t0) && std::isfinite(t->t1);
            r.expect(ordered, "interval", ray, full, [&] {
                return name + ": intersect returned " + format_interval(*t) + ", not an ordered finite interval";
            });
            if (!ordered) continue;
            // Entry, exit and three points between; the first point outside is reported.
            int outside = -1;
            for (int s = 0; s <= 4 && outside < 0; ++s) {
                const float t_at = s == 4 ? t->t1 : t->t0 + (t->t1 - t->t0) * (static_cast<float>(s) * 0.25f);
                if (!detail::inside_with_slack(box, ray.at(t_at), detail::slack_of(box, ray, t_at, cfg.bounds_slack)))
                    outside = s;
            }
            r.expect(outside < 0, "bounds", ray, full, [&] {
                const float t_at = outside == 4 ? t->t1 : t->t0 + (t->t1 - t->t0) * (static_cast<float>(outside) * 0.25f);
                return name + ": intersect " + format_interval(*t) + " reaches " + format_vec3(ray.at(t_at)) +
                       " at t = " + std::to_string(t_at) + ", outside bounds() (bounds too small or intersect too long)";
            });
            // A sub-range: the same interval clipped to it, exactly.
            const float a = t->t0 + (t->t1 - t->t0) * rng.uniform(-0.5f, 0.6f);
            const Interval sub{a, a + (t->t1 - t->t0) * rng.uniform(0.1f, 1.0f)};
            const std::optional<Interval> clipped = intersect_element(e, ray, sub);
            const Interval want{std::max(t->t0, sub.t0), std::min(t->t1, sub.t1)};
            const bool same = want.empty() ? !clipped.has_value() : (clipped && *clipped == want);
            r.expect(same, "range", ray, sub, [&] {
                return name + ": intersect over the range gives " +
                       (clipped ? format_interval(*clipped) : std::string("no hit")) + ", the full interval " +
                       format_interval(*t) + " clipped to it is " +
                       (want.empty() ? std::string("no hit") : format_interval(want));
            });
        }
    }
    r.notes.push_back("bounds: " + std::to_string(instances.size()) + " instances, " +
                      std::to_string(instances.size() * cfg.rays_per_instance) + " rays, " + std::to_string(hits) +
                      " intervals sampled");
    r.expect(hits > 0, "bounds", Ray{}, full, [] {
        return std::string("no probe ray hit any instance: intersect never reports a hit");
    });
    return r;
}

/// What an element does to a ray (RayInteraction: optical depth and colour over an interval):
/// over every sampled interval the optical depth is >= 0 (not NaN) and the colour finite; the
/// contribution's interval lies inside intersect's; and the medium is additive: depth over
/// [t0, s] plus depth over [s, t1] equals depth over [t0, t1] within `relative` (integrators
/// split an element's interval where leaves meet).
template <RayInteraction E>
    requires Intersectable<E>
Report check_medium(std::span<const E> instances, const ConformanceConfig& cfg = {}, float relative = 1e-4f) {
    Report r;
    r.max_reports = cfg.max_reports;
    Rng rng(cfg.seed ^ 0x3ED1A3ull);
    const Interval full{-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
    auto depth = [](const std::optional<Contribution>& c) { return c ? c->optical_depth : 0.0f; };
    std::size_t sampled = 0;
    for (std::size_t k = 0; k < instances.size(); ++k) {
        const E& e = instances[k];
        const Aabb box = bounds_of(e);
        if (box.empty() || !box.finite()) continue;
        const std::string name = "instance " + std::to_string(k);
        for (const Ray& ray : detail::rays_at(box, cfg.rays_per_instance / 2, rng)) {
            const std::optional<Interval> t = intersect_element(e, ray, full);
            if (!t || !(t->t0 < t->t1)) continue;
            ++sampled;
            const std::optional<Contribution> whole = interact_element(e, ray, *t);
            const bool sane = !whole || (whole->optical_depth >= 0.0f && std::isfinite(whole->rgb.x) &&
                                         std::isfinite(whole->rgb.y) && std::isfinite(whole->rgb.z) &&
                                         whole->interval.t0 >= t->t0 && whole->interval.t1 <= t->t1);
            r.expect(sane, "medium", ray, *t, [&] {
                return name + ": interact over " + format_interval(*t) + " gives optical depth " +
                       std::to_string(whole->optical_depth) + ", colour " + format_vec3(whole->rgb) + " over " +
                       format_interval(whole->interval) + " (needs depth >= 0, finite colour, inside the interval)";
            });
            const float split = t->t0 + (t->t1 - t->t0) * rng.uniform(0.1f, 0.9f);
            const float a = depth(interact_element(e, ray, Interval{t->t0, split}));
            const float b = depth(interact_element(e, ray, Interval{split, t->t1}));
            const float w = depth(whole);
            const bool additive = (a + b == w) || std::fabs(a + b - w) <= relative * std::max(w, 1e-3f);
            r.expect(additive, "medium", ray, *t, [&] {
                return name + ": optical depth over " + format_interval(*t) + " is " + std::to_string(w) +
                       ", but split at t = " + std::to_string(split) + " the halves give " + std::to_string(a) +
                       " + " + std::to_string(b) + " (the medium is not additive over an interval)";
            });
        }
    }
    r.notes.push_back("medium: " + std::to_string(instances.size()) + " instances, " + std::to_string(sampled) +
                      " intervals split");
    return r;
}

namespace detail {

/// Rays through a scene box: random, axis-parallel, starting inside, limited ranges.
inline std::vector<std::pair<Ray, Interval>> scene_rays(const Aabb& box, std::size_t count, Rng& rng) {
    std::vector<std::pair<Ray, Interval>> rays;
    const float diagonal = glm::length(box.extent()) + 1e-6f;
    const vec3 c = box.center();
    for (std::size_t i = 0; i < count; ++i) {
        const vec3 target = rng.in_box(box);
        Ray ray;
        Interval range;
        switch (i % 6) {
            case 0: {  // axis-parallel
                vec3 d(0.0f);
                d[static_cast<int>(rng.bits() % 3u)] = (rng.bits() & 1u) != 0u ? 1.0f : -1.0f;
                ray = {target - d * diagonal, d};
                break;
            }
            case 1:  // from inside
                ray = {target, rng.direction()};
                break;
            case 2: {  // a limited range
                vec3 d = rng.direction();
                ray = {c - d * diagonal, d};
                float a = rng.uniform(0.0f, 1.5f * diagonal);
                range = {a, a + rng.uniform(0.0f, diagonal)};
                break;
            }
            default: {
                vec3 d = rng.direction();
                ray = {target - d * (diagonal * rng.uniform(0.6f, 2.0f)), d * rng.uniform(0.5f, 3.0f)};
            }
        }
        rays.emplace_back(ray, range);
    }
    return rays;
}

/// all_hits sorted by hit_before, no element twice; first_hit its front.
inline void check_order(Report& r, const char* structure, const Ray& ray, Interval range,
                        std::span<const bih::ElementHit> all, const std::optional<bih::ElementHit>& first) {
    bool sorted = std::is_sorted(all.begin(), all.end(), bih::hit_before);
    std::vector<std::uint32_t> ids;
    for (const bih::ElementHit& h : all) ids.push_back(h.element);
    std::sort(ids.begin(), ids.end());
    bool unique = std::adjacent_find(ids.begin(), ids.end()) == ids.end();
    std::string check = std::string(structure) + ".order";
    r.expect(sorted && unique, check.c_str(), ray, range, [&] {
        return std::string(sorted ? "an element is reported twice: " : "all_hits is not in (entry t, element) order: ") +
               format_hits(all);
    });
    bool front = all.empty() ? !first.has_value() : (first && *first == all.front());
    r.expect(front, check.c_str(), ray, range, [&] {
        return "first_hit " + (first ? "e" + std::to_string(first->element) + " " + format_interval(first->t)
                                     : std::string("none")) +
               " is not the first of all_hits: " + format_hits(all);
    });
}

/// One structure's queries against brute force over `rays`. `query(ray, range, all)` fills
/// all_hits and returns first_hit.
template <class E, class Query>
void check_queries(Report& r, const char* structure, std::span<const E> scene,
                   std::span<const std::pair<Ray, Interval>> rays, Query&& query) {
    std::vector<bih::ElementHit> all;
    std::size_t hit_rays = 0;
    const std::string all_name = std::string(structure) + ".all_hits";
    const std::string first_name = std::string(structure) + ".first_hit";
    for (const auto& [ray, range] : rays) {
        const std::vector<bih::ElementHit> expected = bih::brute_force_hits(scene, ray, range);
        hit_rays += expected.empty() ? 0 : 1;
        std::optional<bih::ElementHit> first;
        try {
            first = query(ray, range, all);
        } catch (const std::exception& e) {
            r.expect(false, all_name.c_str(), ray, range, [&] { return std::string("threw: ") + e.what(); });
            continue;
        }
        r.expect(all == expected, all_name.c_str(), ray, range, [&] {
            return "expected " + format_hits(expected) + "; got " + format_hits(all);
        });
        const bool first_ok = expected.empty() ? !first.has_value() : (first && *first == expected.front());
        r.expect(first_ok, first_name.c_str(), ray, range, [&] {
            return "expected " + (expected.empty() ? std::string("no hit") : format_hits(std::span(expected).first(1))) +
                   "; got " + (first ? format_hits(std::span(&*first, 1)) : std::string("no hit"));
        });
        check_order(r, structure, ray, range, all, first);
    }
    r.notes.push_back(std::string(structure) + ": " + std::to_string(scene.size()) + " elements, " +
                      std::to_string(rays.size()) + " rays (" + std::to_string(hit_rays) + " hit)");
}

template <class E>
Aabb scene_box(std::span<const E> scene) {
    Aabb box;
    for (const E& e : scene) box.extend(bounds_of(e));
    return box;
}

}  // namespace detail

/// BIH, element octree and element kd-tree queries over `scene` against brute force, and the
/// ordering of their hits (see the top of the file). `moved` (same size as scene, or empty)
/// checks each structure again after its update onto it (ConformanceConfig::check_updates):
/// bih::refit, kdtree::refit_elements, octree::refit_elements of a tree built with
/// refit_margin 1 (its lattice three times the scene's box; where a moved instance leaves even
/// that, the check says so and rebuilds) and octree::rebuild_elements of the default tree.
template <Intersectable E>
Report check_structures(std::span<const E> scene, const ConformanceConfig& cfg = {}, std::span<const E> moved = {}) {
    Report r;
    r.max_reports = cfg.max_reports;
    if (scene.empty()) {
        r.expect(false, "structures", Ray{}, Interval{}, [] { return std::string("empty scene"); });
        return r;
    }
    Rng rng(cfg.seed ^ 0x5CE7E5ull);
    const Aabb box = detail::scene_box(scene);
    const std::vector<std::pair<Ray, Interval>> rays = detail::scene_rays(box, cfg.structure_rays, rng);
    const bool updates = cfg.check_updates && moved.size() == scene.size();
    SerialExecutor serial;
    // The octree's queries over any of its trees (after a build, a refit or a rebuild).
    auto check_octree = [&](const char* name, const octree::ElementTree& tree, std::span<const E> elements,
                            const std::vector<std::pair<Ray, Interval>>& probes) {
        const std::vector<std::uint32_t> words = octree::encode_elements(tree);
        detail::check_queries(r, name, elements, probes, [&](const Ray& ray, Interval range, std::vector<bih::ElementHit>& all) {
            octree::all_hits(words, elements, ray, all, range);
            return octree::first_hit(words, elements, ray, range);
        });
    };
    if (cfg.check_bih) {
        bih::Tree tree = bih::build(scene);
        std::vector<std::uint32_t> words = bih::encode(tree, scene, bih::RangePayload{});
        detail::check_queries(r, "bih", scene, rays, [&](const Ray& ray, Interval range, std::vector<bih::ElementHit>& all) {
            bih::all_hits(words, tree, scene, ray, all, range);
            return bih::first_hit(words, tree, scene, ray, range);
        });
        if (updates) {
            bih::refit(tree, moved, serial);
            words = bih::encode(tree, moved, bih::RangePayload{});
            const std::vector<std::pair<Ray, Interval>> moved_rays =
                detail::scene_rays(detail::scene_box(moved), cfg.structure_rays / 2, rng);
            detail::check_queries(r, "bih.refit", moved, moved_rays,
                                  [&](const Ray& ray, Interval range, std::vector<bih::ElementHit>& all) {
                                      bih::all_hits(words, tree, moved, ray, all, range);
                                      return bih::first_hit(words, tree, moved, ray, range);
                                  });
        }
    }
    if (cfg.check_octree) {
        octree::ElementTree tree = octree::build_elements(scene);
        check_octree("octree", tree, scene, rays);
        if (updates) {
            const std::vector<std::pair<Ray, Interval>> moved_rays =
                detail::scene_rays(detail::scene_box(moved), cfg.structure_rays / 2, rng);
            octree::rebuild_elements(tree, moved, octree::ElementConfig{}, serial);
            check_octree("octree.rebuild", tree, moved, moved_rays);
            octree::ElementConfig roomy;
            roomy.refit_margin = 1.0f;
            octree::ElementTree loose = octree::build_elements(scene, roomy, serial);
            if (octree::refit_elements(loose, moved, roomy, serial)) {
                check_octree("octree.refit", loose, moved, moved_rays);
            } else {
                r.notes.push_back("octree.refit: a moved instance left the lattice of refit_margin 1; rebuilt instead");
                octree::rebuild_elements(loose, moved, roomy, serial);
                check_octree("octree.refit_fallback", loose, moved, moved_rays);
            }
        }
    }
    if (cfg.check_kdtree) {
        kdtree::ElementTree tree = kdtree::build_elements(scene);
        std::vector<std::uint32_t> words = kdtree::encode_elements(tree);
        detail::check_queries(r, "kdtree", scene, rays, [&](const Ray& ray, Interval range, std::vector<bih::ElementHit>& all) {
            kdtree::all_hits(words, scene, ray, all, range);
            return kdtree::first_hit(words, scene, ray, range);
        });
        if (updates) {
            kdtree::refit_elements(tree, moved, kdtree::ElementConfig{}, serial);
            words = kdtree::encode_elements(tree);
            const std::vector<std::pair<Ray, Interval>> moved_rays =
                detail::scene_rays(detail::scene_box(moved), cfg.structure_rays / 2, rng);
            detail::check_queries(r, "kdtree.refit", moved, moved_rays,
                                  [&](const Ray& ray, Interval range, std::vector<bih::ElementHit>& all) {
                                      kdtree::all_hits(words, moved, ray, all, range);
                                      return kdtree::first_hit(words, moved, ray, range);
                                  });
        }
    }
    return r;
}

/// Everything the kit checks on the host for an element type: bounds on generated instances,
/// then the structures on a generated scene (refit onto a second generated scene), and on a
/// scene of one instance repeated (every hit a tie: the order must fall back to the index).
/// `generate` is called as generate(rng) or generate(index, rng) and returns an E.
template <Bounded E, class Gen>
Report check_element_type(Gen&& generate, const ConformanceConfig& cfg = {}) {
    using C = Checked<E>;
    Report r;
    r.max_reports = cfg.max_reports;
    Rng rng(cfg.seed);
    const std::vector<C> probes = detail::generate<E>(generate, cfg.bounds_instances, rng);
    r.merge(check_bounds(std::span<const C>(probes), cfg));
    if constexpr (RayInteraction<C>) r.merge(check_medium(std::span<const C>(probes), cfg));
    const std::vector<C> scene = detail::generate<E>(generate, cfg.element_count, rng);
    const std::vector<C> moved = detail::generate<E>(generate, cfg.element_count, rng);
    r.merge(check_structures(std::span<const C>(scene), cfg, std::span<const C>(moved)));
    if (cfg.coincident_copies > 0 && !scene.empty()) {
        const std::vector<C> copies(cfg.coincident_copies, scene.front());
        ConformanceConfig small = cfg;
        small.structure_rays = std::min<std::size_t>(cfg.structure_rays, 300);
        Report ties = check_structures(std::span<const C>(copies), small);
        for (std::string& note : ties.notes) note = "coincident " + note;
        r.merge(ties);
    }
    return r;
}

// ---- host against a device ---------------------------------------------------------------

/// One ray's result as a device kernel reports it: the first hit and how many elements it hit.
struct RayHits {
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    std::uint32_t first = kNone;  ///< element index of the first hit, kNone when none
    Interval t{0.0f, 0.0f};       ///< its entry and exit
    std::uint32_t count = 0;      ///< elements hit
};

/// The host's RayHits for `rays` (brute force: the reference every structure must equal), with
/// the second-nearest entry per ray for near-tie decisions.
template <Intersectable E>
std::vector<RayHits> host_ray_hits(std::span<const E> elements, std::span<const Ray> rays, Interval range = {}) {
    std::vector<RayHits> out(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const std::vector<bih::ElementHit> all = bih::brute_force_hits(elements, rays[i], range);
        out[i].count = static_cast<std::uint32_t>(all.size());
        if (!all.empty()) {
            out[i].first = all.front().element;
            out[i].t = all.front().t;
        }
    }
    return out;
}

/// Compares a device's RayHits with the host's, ray by ray: equal counts, equal first elements
/// (or, where the host's two nearest entries are within the tolerance, either of them), entry
/// and exit within `relative_tolerance` (0: bit for bit). `elements` lets near ties be found.
template <Intersectable E>
Report compare_ray_hits(std::span<const E> elements, std::span<const Ray> rays, std::span<const RayHits> host,
                        std::span<const RayHits> device, float relative_tolerance, Interval range = {},
                        std::size_t max_reports = 8) {
    Report r;
    r.max_reports = max_reports;
    auto close = [&](float a, float b) {
        return a == b || std::fabs(a - b) <= relative_tolerance * std::max(1.0f, std::fabs(b));
    };
    r.expect(host.size() == rays.size() && device.size() == rays.size(), "device", Ray{}, range, [&] {
        return "sizes differ: " + std::to_string(rays.size()) + " rays, " + std::to_string(host.size()) +
               " host and " + std::to_string(device.size()) + " device results";
    });
    if (host.size() != rays.size() || device.size() != rays.size()) return r;
    std::size_t exact = 0, ties = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const RayHits& h = host[i];
        const RayHits& d = device[i];
        bool same_first = d.first == h.first;
        if (!same_first && h.first != RayHits::kNone && d.first < elements.size()) {
            // A near tie: the device's element enters within the tolerance of the host's first.
            const std::optional<Interval> t = intersect_element(elements[d.first], rays[i], range);
            if (t && close(t->t0, h.t.t0)) {
                same_first = true;
                ++ties;
            }
        }
        const bool times = h.first == RayHits::kNone || d.first != h.first ||
                           (close(d.t.t0, h.t.t0) && close(d.t.t1, h.t.t1));
        exact += (d.first == h.first && d.count == h.count && (h.first == RayHits::kNone || d.t == h.t)) ? 1 : 0;
        r.expect(same_first && times && d.count == h.count, "device", rays[i], range, [&] {
            auto side = [](const RayHits& x) {
                return (x.first == RayHits::kNone ? std::string("no hit") : "e" + std::to_string(x.first) + " " +
                                                                              format_interval(x.t)) +
                       " of " + std::to_string(x.count) + " hits";
            };
            return "ray " + std::to_string(i) + ": host first " + side(h) + ", device " + side(d);
        });
    }
    r.notes.push_back("device: " + std::to_string(rays.size()) + " rays, " + std::to_string(exact) +
                      " bit for bit, " + std::to_string(ties) + " near ties");
    return r;
}

}  // namespace sylva::testing

#endif  // SYLVA_TESTING_CONFORMANCE_HPP
