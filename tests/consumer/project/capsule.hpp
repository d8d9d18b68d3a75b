// capsule.hpp -- the host side of the user's capsule: the scene generator the host and GPU
// checks share. The type itself is capsule.h (one definition for C++ and GLSL).
#ifndef CONSUMER_CAPSULE_HPP
#define CONSUMER_CAPSULE_HPP

#include <sylva/core/concepts.hpp>
#include <sylva/testing/conformance.hpp>

#include <vector>

#include "capsule.h"

namespace consumer {

static_assert(sylva::Intersectable<Capsule> && sylva::RayInteraction<Capsule>,
              "the capsule, written once in the shared subset, is a C++ element type");

/// One capsule in [0, 1]^3 (the conformance kit's generator signature).
inline Capsule random_capsule(sylva::testing::Rng& rng) {
    Capsule c;
    c.a = rng.in_box({sylva::vec3(0.0f), sylva::vec3(1.0f)});
    c.b = c.a + sylva::vec3(rng.uniform(-0.08f, 0.08f), rng.uniform(-0.08f, 0.08f), rng.uniform(-0.08f, 0.08f));
    c.radius = rng.uniform(0.004f, 0.02f);
    c.extinction = rng.uniform(5.0f, 60.0f);
    c.rgb = sylva::vec3(rng.uniform(), rng.uniform(), rng.uniform());
    return c;
}

/// n capsules from a fixed seed: the same scene on every run and platform.
inline std::vector<Capsule> make_capsules(std::size_t n, std::uint64_t seed = 12345u) {
    sylva::testing::Rng rng(seed);
    std::vector<Capsule> out;
    for (std::size_t i = 0; i < n; ++i) out.push_back(random_capsule(rng));
    return out;
}

}  // namespace consumer

#endif  // CONSUMER_CAPSULE_HPP
