// Built against the installed package only. Include every public header a user would, and
// check one real result from each, so a header that fails to install (or to compile outside
// the source tree) fails here. Add new headers to the list below.
//
// The host half of the user-element check: the user's capsule (capsule.h, written once in the
// shared subset) through the installed conformance kit from a plain main: bounds against
// sampled intervals, BIH / element octree / element kd-tree queries against brute force, order,
// refit; then the shared element kernels on the host (hits in order) against brute force.
#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/core/error.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/elements.hpp>
#include <sylva/shared/lang.h>
#include <sylva/testing/conformance.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>
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

void check_capsule_conformance() {
    const sylva::testing::Report report = sylva::testing::check_element_type<consumer::Capsule>(consumer::random_capsule);
    std::cout << report;
    check(report.ok(), "the capsule passes the conformance kit");
}

/// The shared element kernel on the host (what the GPU runs) gives brute force's hits in order.
void check_shared_kernel_on_host() {
    const std::vector<consumer::Capsule> capsules = consumer::make_capsules(3000);
    const std::span<const consumer::Capsule> view(capsules);
    const sylva::bih::Tree tree = sylva::bih::build(view);
    const std::vector<std::uint32_t> words = sylva::bih::encode(tree, view, sylva::bih::RangePayload{});
    const std::vector<std::uint32_t> records = sylva::pack_elements(view, std::span<const std::uint32_t>(tree.order));
    sylva::testing::Rng rng(5);
    std::size_t rays = 0, wrong = 0, hit = 0;
    for (int i = 0; i < 2000; ++i) {
        const sylva::vec3 target = rng.in_box({sylva::vec3(0.0f), sylva::vec3(1.0f)});
        const sylva::vec3 d = rng.direction();
        const sylva::Ray ray{target - 2.0f * d, d};
        const std::vector<sylva::bih::ElementHit> expected = sylva::bih::brute_force_hits(view, ray);
        const sylva::ElementHits got = sylva::element_hits_cpu<consumer::Capsule>(words, records, ray, sylva::Interval{});
        bool same = got.hits.size() == expected.size() && got.status == SYLVA_ITER_DONE;
        for (std::size_t k = 0; same && k < expected.size(); ++k) {
            const auto& h = got.hits[k];
            same = tree.order[h.elem] == expected[k].element && h.t0 == expected[k].t.t0 && h.t1 == expected[k].t.t1;
        }
        ++rays;
        hit += expected.empty() ? 0 : 1;
        if (!same && ++wrong <= 3)
            std::fprintf(stderr, "sylva_consumer: shared kernel differs from brute force on ray %d\n", i);
    }
    std::printf("sylva_consumer: shared element kernel on the host: %zu rays (%zu hit), %zu differ\n", rays, hit, wrong);
    check(hit > rays / 4 && wrong == 0, "the shared element kernel's hits equal brute force");
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
        check_capsule_conformance();
        check_shared_kernel_on_host();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sylva_consumer: FAILED: %s\n", e.what());
        ++failures;
    }

    if (failures == 0) std::puts("sylva_consumer: OK");
    return failures == 0 ? 0 : 1;
}
