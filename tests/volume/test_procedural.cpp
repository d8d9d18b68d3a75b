// Procedural volumes against their closed forms: Marschner-Lobb, exact fields, and the
// properties the sparse N-body stand-in promises (deterministic, normalised, mostly empty).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <sylva/volume/classify.hpp>
#include <sylva/volume/procedural.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;

namespace {
/// Marschner and Lobb's signal in double precision, written out independently.
double ml_reference(double x, double y, double z, double fm = 6.0, double alpha = 0.25) {
    const double pi = 3.14159265358979323846;
    double rho_r = std::cos(2.0 * pi * fm * std::cos(pi * std::sqrt(x * x + y * y) / 2.0));
    return (1.0 - std::sin(pi * z / 2.0) + alpha * (1.0 + rho_r)) / (2.0 * (1.0 + alpha));
}
}  // namespace

TEST_CASE("Marschner-Lobb: voxel centres map onto [-1, 1]^3", "[procedural]") {
    DensityGrid g = marschner_lobb(Dims(41, 41, 41));
    REQUIRE(g.values.size() == 41u * 41u * 41u);
    CHECK(g.at(20, 20, 20) == Approx(0.6).margin(1e-6));  // the centre: (1 + 0.25 * 2) / 2.5
    for (std::uint32_t z = 0; z < 41; z += 5)
        for (std::uint32_t y = 0; y < 41; y += 3)
            for (std::uint32_t x = 0; x < 41; x += 7) {
                auto p = [](std::uint32_t i) { return -1.0 + 2.0 * (i + 0.5) / 41.0; };
                CHECK(g.at(x, y, z) == Approx(ml_reference(p(x), p(y), p(z))).margin(2e-5));
            }
    auto [lo, hi] = std::minmax_element(g.values.begin(), g.values.end());
    CHECK(*lo >= 0.0f);
    CHECK(*hi <= 1.0f);
    CHECK(*hi > 0.95f);  // the signal spans (nearly) all of [0, 1]
    CHECK(*lo < 0.05f);
    MarschnerLobbConfig other;
    other.f_m = 3.0f;
    other.alpha = 0.5f;
    other.spacing = vec3(2.0f);
    DensityGrid h = marschner_lobb(Dims(10, 12, 14), other);
    CHECK(h.spacing == vec3(2.0f));
    CHECK(h.at(3, 4, 5) ==
          Approx(ml_reference(-1.0 + 7.0 / 10.0, -1.0 + 9.0 / 12.0, -1.0 + 11.0 / 14.0, 3.0, 0.5)).margin(2e-5));
    CHECK(marschner_lobb_at(vec3(0.0f, 0.0f, -1.0f)) == Approx(1.0f));
    CHECK_THROWS_WITH(marschner_lobb(Dims(0, 4, 4)), Contains("marschner_lobb") && Contains("zero"));
}

TEST_CASE("constant_box, linear_ramp and radial_falloff hold their closed forms", "[procedural]") {
    DensityGrid box = constant_box(Dims(8, 7, 6), 0.75f, glm::u32vec3(1, 2, 3), glm::u32vec3(4, 7, 5));
    CHECK(count_classified(box, DensityThreshold{0.5f}) == 3u * 5u * 2u);
    CHECK(box.at(1, 2, 3) == 0.75f);
    CHECK(box.at(3, 6, 4) == 0.75f);
    CHECK(box.at(4, 6, 4) == 0.0f);
    CHECK(box.at(0, 2, 3) == 0.0f);
    DensityGrid full = constant_box(Dims(3, 3, 3), 1.0f);
    CHECK(count_classified(full, DensityThreshold{1.0f}) == 27);
    DensityGrid ramp = linear_ramp(Dims(4, 4, 4), vec3(0.1f, 0.0f, 0.05f), 0.2f, vec3(2.0f));
    CHECK(ramp.at(3, 1, 2) == 1.0f);  // centre (7, 3, 5): 0.2 + 0.7 + 0.25 = 1.15, clamped
    CHECK(ramp.at(1, 0, 0) == Approx(0.2 + 0.1 * 3.0 + 0.05 * 1.0));
    DensityGrid ball = radial_falloff(Dims(9, 9, 9), vec3(4.5f), 4.0f);
    CHECK(ball.at(4, 4, 4) == 1.0f);  // centre voxel at the centre
    CHECK(ball.at(6, 4, 4) == Approx(1.0 - 2.0 / 4.0));
    CHECK(ball.at(0, 0, 0) == 0.0f);  // sqrt(48) > 4: clamped
    // Isosurface of level 0.5 is the sphere of radius 2: count centres with |c - 4.5| <= 2.
    std::size_t inside = 0;
    for (int z = 0; z < 9; ++z)
        for (int y = 0; y < 9; ++y)
            for (int x = 0; x < 9; ++x)
                inside += (x - 4) * (x - 4) + (y - 4) * (y - 4) + (z - 4) * (z - 4) <= 4 ? 1u : 0u;
    CHECK(count_classified(ball, DensityThreshold{0.5f}) == inside);
    CHECK_THROWS_WITH(constant_box(Dims(4, 4, 4), 1.5f), Contains("not in [0, 1]"));
    CHECK_THROWS_WITH(constant_box(Dims(4, 4, 4), 0.5f, glm::u32vec3(2), glm::u32vec3(1)),
                      Contains("lo <= hi <= dims"));
    CHECK_THROWS_WITH(constant_box(Dims(4, 4, 4), 0.5f, glm::u32vec3(0), glm::u32vec3(5)),
                      Contains("lo <= hi <= dims"));
    CHECK_THROWS_WITH(constant_box(Dims(4, 4, 4), 0.5f, vec3(0.0f)), Contains("spacing"));
    CHECK_THROWS_WITH(linear_ramp(Dims(4, 4, 4), vec3(std::nanf("")), 0.0f), Contains("finite"));
    CHECK_THROWS_WITH(radial_falloff(Dims(4, 4, 4), vec3(1.0f), 0.0f), Contains("radius"));
    CHECK_THROWS_WITH(constant_box(Dims(4294967295u, 4294967295u, 16u), 0.5f), Contains("overflow"));
}

TEST_CASE("sparse_nbody: deterministic, normalised, mostly empty, clustered", "[procedural]") {
    const Dims dims(64, 64, 64);
    DensityGrid a = sparse_nbody(dims, 42);
    DensityGrid b = sparse_nbody(dims, 42);
    DensityGrid c = sparse_nbody(dims, 43);
    CHECK(a.values == b.values);
    CHECK(a.values != c.values);
    auto [lo, hi] = std::minmax_element(a.values.begin(), a.values.end());
    CHECK(*lo == 0.0f);
    CHECK(*hi == 1.0f);
    std::size_t n = a.values.size();
    std::size_t nonzero = count_classified(a, [](float d) { return d > 0.0f; });
    std::size_t dense = count_classified(a, DensityThreshold{});
    INFO("nonzero " << nonzero << ", >= 0.1: " << dense << " of " << n);
    CHECK(nonzero < n / 2);  // mostly empty space
    CHECK(dense < n / 10);
    CHECK(dense > n / 500);  // but not nothing
    // Clustered: the densest eighth of the 8^3-voxel blocks holds most of the mass.
    std::vector<double> block(512, 0.0);
    for (std::uint32_t z = 0; z < 64; ++z)
        for (std::uint32_t y = 0; y < 64; ++y)
            for (std::uint32_t x = 0; x < 64; ++x) block[(x / 8) + 8 * ((y / 8) + 8 * (z / 8))] += a.at(x, y, z);
    std::sort(block.begin(), block.end(), std::greater<>());
    double total = 0.0, top = 0.0;
    for (std::size_t i = 0; i < block.size(); ++i) {
        total += block[i];
        if (i < 64) top += block[i];  // the densest eighth of the blocks
    }
    CHECK(top > 0.5 * total);
    SparseNbodyConfig bad;
    bad.halo_share = 0.8f;
    bad.field_share = 0.5f;
    CHECK_THROWS_WITH(sparse_nbody(dims, 1, bad), Contains("shares"));
    CHECK_THROWS_WITH(sparse_nbody(Dims(0, 1, 1), 1), Contains("zero"));
}
