// conformance.* (vulkan): the kit's host-against-device check (sylva/testing/conformance_vulkan.hpp)
// on lavapipe for the library's elements, and its failure on a kernel that reads the records
// as another element type.
#include <catch2/catch.hpp>

#include <sylva/spirv/elements_rbf.h>
#include <sylva/spirv/elements_sphere.h>

#include "sylva/elements/rbf.hpp"
#include "sylva/elements/sphere.hpp"
#include "sylva/testing/conformance_vulkan.hpp"

using sylva::vec3;
using sylva::vec4;
using sylva::testing::Rng;

namespace {

sylva::Sphere random_sphere(Rng& rng) {
    sylva::Sphere s;
    s.center = rng.in_box({vec3(-5.0f), vec3(5.0f)});
    s.radius = rng.uniform(0.05f, 0.5f);
    s.rgba = vec4(rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(0.2f, 1.0f));
    s.kappa = rng.uniform(0.5f, 4.0f);
    return s;
}

sylva::GaussianRbf random_rbf(Rng& rng) {
    sylva::GaussianRbf g;
    g.center = rng.in_box({vec3(0.0f), vec3(10.0f)});
    g.sigma = rng.uniform(0.02f, 0.2f);
    g.truncation = rng.uniform(1.5f, 4.0f);
    return g;
}

sylva::vk::Context& context() {
    static sylva::vk::Context ctx = sylva::vk::Context::create();
    return ctx;
}

}  // namespace

TEST_CASE("spheres: the device's hit sequences equal brute force bit for bit", "[conformance][vulkan]") {
    const sylva::testing::Report r =
        sylva::testing::check_device<sylva::Sphere>(context(), sylva::spirv::elements_sphere, random_sphere);
    INFO(r);
    CHECK(r.ok());
    CHECK(r.checks > 3000);
}

TEST_CASE("Gaussian RBFs: the device's hit sequences equal brute force bit for bit", "[conformance][vulkan]") {
    const sylva::testing::Report r =
        sylva::testing::check_device<sylva::GaussianRbf>(context(), sylva::spirv::elements_rbf, random_rbf);
    INFO(r);
    CHECK(r.ok());
}

TEST_CASE("the device check fails on a kernel compiled for another element, naming the ray",
          "[conformance][vulkan][broken]") {
    // The sphere kernel reads an RBF's sigma as the radius: its intervals are too short.
    const sylva::testing::Report r =
        sylva::testing::check_device<sylva::GaussianRbf>(context(), sylva::spirv::elements_sphere, random_rbf);
    CHECK_FALSE(r.ok());
    const std::string text = sylva::testing::to_string(r);
    INFO(text);
    CHECK(text.find("device.hits: expected") != std::string::npos);
    CHECK(text.find("the device gave") != std::string::npos);
    CHECK(text.find("ray origin (") != std::string::npos);
}
