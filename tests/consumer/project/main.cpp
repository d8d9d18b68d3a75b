// Built against the installed package only. Include every public header a user would, and
// check one real result from each, so a header that fails to install (or to compile outside
// the source tree) fails here. Add new headers to the list below.
//
// The host half of the user-element check: a BIH and an element octree over the user's capsules
// (capsule.hpp, one definition in capsule.h), first hit and all hits equal to brute force.
#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/core/error.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/shared/lang.h>

#include <cmath>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "capsule.hpp"

namespace {

int failures = 0;

void check(bool ok, const char* what) {
    if (!ok) {
        std::fprintf(stderr, "sylva_consumer: FAILED: %s\n", what);
        ++failures;
    }
}

/// Rays from outside the unit cube through it, on a fixed lattice of directions.
std::vector<sylva::Ray> probe_rays(int n) {
    std::vector<sylva::Ray> rays;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            const float u = (static_cast<float>(i) + 0.5f) / static_cast<float>(n);
            const float v = (static_cast<float>(j) + 0.5f) / static_cast<float>(n);
            const sylva::vec3 origin(-0.5f, 0.3f * u - 0.1f, 0.2f * v - 0.3f);
            const sylva::vec3 target(1.5f, u, v);
            rays.push_back({origin, target - origin});
        }
    }
    return rays;
}

void check_capsules_on_host() {
    const std::vector<consumer::Capsule> capsules = consumer::make_capsules(3000);
    const std::span<const consumer::Capsule> view(capsules);
    const sylva::bih::Tree tree = sylva::bih::build(view);
    const std::vector<std::uint32_t> words = sylva::bih::encode(tree, view, sylva::bih::RangePayload{});
    const sylva::octree::ElementTree octree = sylva::octree::build_elements(view);
    const std::vector<std::uint32_t> octree_words = sylva::octree::encode_elements(octree);

    std::size_t rays_hit = 0, bih_wrong = 0, octree_wrong = 0;
    std::vector<sylva::bih::ElementHit> hits;
    for (const sylva::Ray& ray : probe_rays(48)) {
        const std::vector<sylva::bih::ElementHit> expected = sylva::bih::brute_force_hits(view, ray);
        const std::optional<sylva::bih::ElementHit> first = sylva::bih::first_hit(words, tree, view, ray);
        sylva::bih::all_hits(words, tree, view, ray, hits);
        if (hits != expected || first.has_value() != !expected.empty() || (first && !(*first == expected.front())))
            ++bih_wrong;
        sylva::octree::all_hits(octree_words, view, ray, hits);
        const auto octree_first = sylva::octree::first_hit(octree_words, view, ray);
        if (hits != expected || octree_first.has_value() != !expected.empty() ||
            (octree_first && !(*octree_first == expected.front())))
            ++octree_wrong;
        rays_hit += expected.empty() ? 0 : 1;
    }
    std::printf("sylva_consumer: 2304 rays, %zu hit capsules; BIH wrong %zu, octree wrong %zu\n", rays_hit,
                bih_wrong, octree_wrong);
    check(rays_hit > 500, "the capsule scene is hit by many probe rays");
    check(bih_wrong == 0, "BIH first hit and all hits over capsules equal brute force");
    check(octree_wrong == 0, "element octree first hit and all hits over capsules equal brute force");
}

}  // namespace

int main() {
    // The shared bridge: 1/-0 must be -inf on the host exactly as in the shaders.
    const float r = sylva::shared::sylva_safe_rcp(-0.0f);
    check(std::isinf(r) && std::signbit(r), "sylva_safe_rcp(-0.0f) == -inf");

    // The library's one exception type.
    try {
        throw sylva::Error("consumer");
    } catch (const std::runtime_error& e) {
        check(std::string(e.what()) == "consumer", "sylva::Error carries its message");
    }

    try {
        check_capsules_on_host();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sylva_consumer: FAILED: %s\n", e.what());
        ++failures;
    }

    if (failures == 0) std::puts("sylva_consumer: OK");
    return failures == 0 ? 0 : 1;
}
