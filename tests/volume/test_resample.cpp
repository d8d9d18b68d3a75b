// Trilinear reconstruction and resampling against independent references: a tent-filter sum
// over all voxels, linear ramps (reproduced exactly), constants, and the geometry rules.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/volume/classify.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/resample.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;

namespace {

/// Reference reconstruction, written differently from the library: the sum over every voxel of
/// its value times the tent weight prod(max(0, 1 - |u - i|)) at the clamped continuous index u.
double tent_reference(const DensityGrid& g, vec3 world) {
    double u[3];
    for (int a = 0; a < 3; ++a)
        u[a] = std::min(std::max(double(world[a]) / double(g.spacing[a]) - 0.5, 0.0), double(g.dims[a]) - 1.0);
    double sum = 0.0;
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x) {
                double w = std::max(0.0, 1.0 - std::abs(u[0] - x)) * std::max(0.0, 1.0 - std::abs(u[1] - y)) *
                           std::max(0.0, 1.0 - std::abs(u[2] - z));
                sum += w * g.at(x, y, z);
            }
    return sum;
}

DensityGrid random_grid(Dims dims, vec3 spacing, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    DensityGrid g{dims, spacing, std::vector<float>(voxel_count(dims))};
    for (float& v : g.values) v = u(rng);
    return g;
}

}  // namespace

TEST_CASE("sample_trilinear matches a tent-filter sum over all voxels, inside and outside", "[resample]") {
    for (Dims dims : {Dims(5, 4, 3), Dims(1, 6, 2), Dims(7, 1, 1)}) {
        DensityGrid g = random_grid(dims, vec3(0.5f, 2.0f, 1.25f), dims.x * 100 + dims.y);
        std::mt19937 rng(dims.x);
        vec3 size = vec3(dims) * g.spacing;
        std::uniform_real_distribution<float> u(-0.3f, 1.3f);  // also beyond the grid: clamped
        for (int i = 0; i < 300; ++i) {
            vec3 p(u(rng) * size.x, u(rng) * size.y, u(rng) * size.z);
            CHECK(sample_trilinear(g, p) == Approx(tent_reference(g, p)).margin(1e-5));
        }
    }
}

TEST_CASE("sample_trilinear hits voxel values at their centres and rejects NaN", "[resample]") {
    DensityGrid g = random_grid(Dims(4, 3, 5), vec3(1.0f, 1.0f, 1.4f), 7);
    for (std::uint32_t z = 0; z < 5; ++z)
        for (std::uint32_t y = 0; y < 3; ++y)
            for (std::uint32_t x = 0; x < 4; ++x) {
                vec3 c = (vec3(float(x), float(y), float(z)) + 0.5f) * g.spacing;
                CHECK(sample_trilinear(g, c) == Approx(g.at(x, y, z)).margin(1e-6));
            }
    CHECK(sample_trilinear(g, vec3(-5.0f)) == g.at(0, 0, 0));  // clamped to the corner voxel
    CHECK(sample_trilinear(g, vec3(100.0f)) == g.at(3, 2, 4));
    CHECK_THROWS_WITH(sample_trilinear(g, vec3(1.0f, std::nanf(""), 1.0f)), Contains("NaN"));
    CHECK_THROWS_AS(sample_trilinear(g, vec3(std::numeric_limits<float>::infinity())), Error);
}

TEST_CASE("resampled dims are round(dims * factor); spacing keeps the world box", "[resample]") {
    CHECK(resampled_dims(Dims(256, 256, 256), 1.5f) == Dims(384, 384, 384));
    CHECK(resampled_dims(Dims(301, 324, 56), 1.5f) == Dims(452, 486, 84));  // 451.5 rounds up
    CHECK(resampled_dims(Dims(7, 5, 3), 2.0f) == Dims(14, 10, 6));
    CHECK(resampled_dims(Dims(7, 5, 3), 0.1f) == Dims(1, 1, 1));  // never below 1
    SerialExecutor serial;
    DensityGrid g = constant_box(Dims(7, 5, 3), 0.25f, vec3(1.0f, 2.0f, 3.0f));
    DensityGrid r = resample_trilinear(g, 1.5f, serial);
    REQUIRE(r.dims == Dims(11, 8, 5));  // 10.5 -> 11, 7.5 -> 8, 4.5 -> 5
    CHECK(r.spacing.x == Approx(7.0 / 11.0));
    CHECK(r.spacing.y == Approx(10.0 / 8.0));
    CHECK(r.spacing.z == Approx(9.0 / 5.0));
    CHECK(r.world_box().hi.x == Approx(g.world_box().hi.x));
    CHECK(r.world_box().hi.z == Approx(g.world_box().hi.z));
}

TEST_CASE("a constant grid stays exactly constant", "[resample]") {
    ThreadPool pool(2);
    DensityGrid g = constant_box(Dims(9, 6, 4), 0.37f);
    for (float factor : {1.5f, 2.0f, 0.5f, 3.3f}) {
        DensityGrid r = resample_trilinear(g, factor, pool);
        for (float v : r.values) REQUIRE(v == 0.37f);
    }
}

TEST_CASE("a linear ramp stays exactly linear inside, and clamps outside", "[resample]") {
    // 0.05 + 0.02 x + 0.03 y + 0.04 z stays inside [0, 1] on this grid, so nothing is clamped.
    const vec3 slope(0.02f, 0.03f, 0.04f), spacing(1.0f, 1.5f, 0.8f);
    const float offset = 0.05f;
    DensityGrid g = linear_ramp(Dims(12, 9, 10), slope, offset, spacing);
    ThreadPool pool(2);
    for (float factor : {1.5f, 2.0f}) {
        DensityGrid r = resample_trilinear(g, factor, pool);
        REQUIRE(r.dims == resampled_dims(g.dims, factor));
        vec3 lo = 0.5f * spacing, hi = (vec3(g.dims) - 0.5f) * spacing;  // source voxel centres
        std::size_t inside = 0;
        for (std::uint32_t z = 0; z < r.dims.z; ++z)
            for (std::uint32_t y = 0; y < r.dims.y; ++y)
                for (std::uint32_t x = 0; x < r.dims.x; ++x) {
                    vec3 c = (vec3(float(x), float(y), float(z)) + 0.5f) * r.spacing;
                    bool in = glm::all(glm::greaterThanEqual(c, lo)) && glm::all(glm::lessThanEqual(c, hi));
                    inside += in ? 1u : 0u;
                    // Inside: the ramp itself. Outside: the ramp at the nearest source centre.
                    vec3 q = glm::clamp(c, lo, hi);
                    double want =
                        double(offset) + double(slope.x) * q.x + double(slope.y) * q.y + double(slope.z) * q.z;
                    REQUIRE(r.at(x, y, z) == Approx(want).margin(2e-6));
                    REQUIRE(r.at(x, y, z) == sample_trilinear(g, c));  // the same rule, bit for bit
                }
        CHECK(inside > r.values.size() / 2);
    }
}

TEST_CASE("resampling rejects bad factors and inconsistent grids", "[resample][errors]") {
    SerialExecutor serial;
    DensityGrid g = constant_box(Dims(2, 2, 2), 0.5f);
    CHECK_THROWS_WITH(resample_trilinear(g, 0.0f, serial), Contains("factor") && Contains("positive"));
    CHECK_THROWS_WITH(resample_trilinear(g, -1.5f, serial), Contains("factor"));
    CHECK_THROWS_WITH(resample_trilinear(g, std::nanf(""), serial), Contains("factor"));
    CHECK_THROWS_WITH(resample_trilinear(g, std::numeric_limits<float>::infinity(), serial), Contains("factor"));
    CHECK_THROWS_WITH(resampled_dims(Dims(4000000000u, 1, 1), 2.0f), Contains("overflows a 32-bit dimension"));
    CHECK_THROWS_WITH(resample_trilinear(g, 3.0e9f, serial), Contains("overflow"));  // 3e9^3 voxels
    DensityGrid bad = g;
    bad.values.resize(7);
    CHECK_THROWS_WITH(resample_trilinear(bad, 2.0f, serial), Contains("7 values for 8 voxels"));
    bad = g;
    bad.spacing.y = 0.0f;
    CHECK_THROWS_WITH(resample_trilinear(bad, 2.0f, serial), Contains("spacing"));
}

TEST_CASE("aneurism supersampled by 1.5 and 2: voxels >= 0.1 within 0.15% of Kinkelin's Table 6", "[resample][data]") {
    auto path = volume_test::data_file("aneurism_256x256x256_uint8.raw");
    if (!path) return;
    DensityGrid g = normalize(read_volume(*path));
    ThreadPool pool(2);
    struct Row {
        float factor;
        double paper;      // Table 6, BIH elements
        std::size_t ours;  // measured here (regression value; the paper is the reference)
    };
    // The tolerance separates resampling grids: voxel centres (ours) land +0.11% over the paper
    // for both factors; node-aligned (j (n-1)/(m-1)) would be +0.44% / +0.25%, and j / factor
    // without the half-voxel shift -0.19% / -1.26%.
    // (Factor 2 counted 977,740 while volume::normalize multiplied by 1/255; with the exact
    // v / 255 of issue 17, 35 interpolated values near 0.1 fall below it: 977,705; blending z
    // first, as NanoVDB's sampler and the renderers do since 2026-11-29, rounds 3 back over it:
    // 977,708. Factor 1.5 is unchanged.)
    for (Row row : {Row{1.5f, 409511.0, 409981}, Row{2.0f, 976669.0, 977708}}) {
        std::size_t n = count_classified(resample_trilinear(g, row.factor, pool), DensityThreshold{});
        INFO("factor " << row.factor << ": " << n << " voxels >= 0.1, paper " << row.paper);
        CHECK(std::abs(double(n) - row.paper) / row.paper < 0.0015);
        CHECK(n == row.ours);
    }
}
