// Gradients (central differences, one-sided at the borders) and the voxel-cuboid source.
#include <catch2/catch.hpp>

#include <sylva/core/executor.hpp>
#include <sylva/volume/gradient.hpp>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;
using volume::DensityGrid;

namespace {

/// d(x, y, z) = f(x, y, z) sampled at integer voxel coordinates.
template <class F>
DensityGrid analytic(volume::Dims dims, vec3 spacing, F f) {
    DensityGrid g{dims, spacing, std::vector<float>(volume::voxel_count(dims))};
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) g.values[volume::voxel_index(dims, x, y, z)] = f(x, y, z);
    return g;
}

}  // namespace

TEST_CASE("gradient of a linear ramp is its slope per voxel everywhere, borders included", "[gradient]") {
    // Spacing must not enter: the gradient is per voxel, not per world unit.
    DensityGrid g = analytic({7, 5, 4}, vec3(2.0f, 0.5f, 1.4f),
                             [](float x, float y, float z) { return 0.01f * x - 0.02f * y + 0.05f * z + 0.1f; });
    for (std::uint32_t z = 0; z < 4; ++z)
        for (std::uint32_t y = 0; y < 5; ++y)
            for (std::uint32_t x = 0; x < 7; ++x) {
                vec3 gr = volume::gradient_at(g, x, y, z);
                CHECK(gr.x == Approx(0.01f).margin(1e-6));
                CHECK(gr.y == Approx(-0.02f).margin(1e-6));
                CHECK(gr.z == Approx(0.05f).margin(1e-6));
            }
}

TEST_CASE("gradient of a quadratic: central inside, one-sided at the borders", "[gradient]") {
    // d = (x/10)^2 along x: central difference (d[i+1]-d[i-1])/2 = 2x/100 exactly; border
    // forward difference d[1]-d[0] = 1/100, backward d[n-1]-d[n-2] = (2n-3)/100.
    const std::uint32_t n = 9;
    DensityGrid g = analytic({n, 2, 1}, vec3(1.0f), [](float x, float, float) { return x * x / 100.0f; });
    CHECK(volume::gradient_at(g, 0, 0, 0).x == Approx(0.01f).margin(1e-6));
    for (std::uint32_t x = 1; x + 1 < n; ++x) CHECK(volume::gradient_at(g, x, 1, 0).x == Approx(2.0f * x / 100.0f).margin(1e-6));
    CHECK(volume::gradient_at(g, n - 1, 0, 0).x == Approx((2.0f * n - 3.0f) / 100.0f).margin(1e-6));
    CHECK(volume::gradient_at(g, 3, 0, 0).y == 0.0f);  // constant along y
    CHECK(volume::gradient_at(g, 3, 0, 0).z == 0.0f);  // a single voxel along z
}

TEST_CASE("whole-grid gradients match gradient_at on every voxel, serial and parallel", "[gradient][parallel]") {
    DensityGrid g = lodtest::synthetic_grid({13, 11, 9}, vec3(1.0f, 1.0f, 1.4f), 3u);
    ThreadPool pool(3);
    std::vector<vec3> serial = volume::gradients(g), parallel = volume::gradients(g, pool);
    REQUIRE(serial.size() == g.values.size());
    REQUIRE(parallel == serial);
    for (std::uint32_t z = 0; z < 9; ++z)
        for (std::uint32_t y = 0; y < 11; ++y)
            for (std::uint32_t x = 0; x < 13; ++x) {
                // independent reference: the formula written out with clamped neighbours
                auto diff = [&](int dx, int dy, int dz, std::uint32_t c, std::uint32_t n) {
                    std::int64_t xi = x, yi = y, zi = z;
                    float hi = g.clamped(xi + dx, yi + dy, zi + dz), lo = g.clamped(xi - dx, yi - dy, zi - dz);
                    return (c == 0 || c == n - 1) ? (hi - lo) : (hi - lo) / 2.0f;
                };
                vec3 want(diff(1, 0, 0, x, 13), diff(0, 1, 0, y, 11), diff(0, 0, 1, z, 9));
                vec3 got = serial[volume::voxel_index(g.dims, x, y, z)];
                REQUIRE(got.x == Approx(want.x).margin(1e-6));
                REQUIRE(got.y == Approx(want.y).margin(1e-6));
                REQUIRE(got.z == Approx(want.z).margin(1e-6));
            }
}

TEST_CASE("voxel_cuboids selects exactly the voxels at or above the threshold, x fastest", "[voxels]") {
    vec3 spacing(1.0f, 2.0f, 1.4f);
    DensityGrid g = lodtest::synthetic_grid({17, 12, 10}, spacing, 5u);
    ThreadPool pool(3);
    for (float threshold : {0.1f, 0.35f, 0.6f}) {
        std::vector<VoxelCuboid> got = volume::voxel_cuboids(g, threshold, pool);
        std::size_t k = 0;
        for (std::uint32_t z = 0; z < 10; ++z)
            for (std::uint32_t y = 0; y < 12; ++y)
                for (std::uint32_t x = 0; x < 17; ++x) {
                    float d = g.at(x, y, z);
                    if (d < threshold) continue;
                    REQUIRE(k < got.size());
                    const VoxelCuboid& c = got[k++];
                    vec3 lo = vec3(x, y, z) * spacing;
                    CHECK(c.box.lo == lo);
                    CHECK(c.box.hi == (vec3(x, y, z) + 1.0f) * spacing);
                    CHECK(c.density == d);
                    CHECK(c.gradient == volume::gradient_at(g, x, y, z));
                }
        CHECK(k == got.size());
        CHECK(volume::voxel_cuboids(g, threshold).size() == got.size());
    }
}

TEST_CASE("voxel_cuboids: nothing selected is an empty result; bad grids throw", "[voxels][bad]") {
    DensityGrid g = lodtest::synthetic_grid({6, 6, 6}, vec3(1.0f), 1u);
    CHECK(volume::voxel_cuboids(g, 1.5f).empty());
    CHECK(volume::voxel_cuboids(g, 0.0f).size() == g.values.size());

    CHECK_THROWS_AS(volume::voxel_cuboids(g, std::nanf("")), Error);
    CHECK_THROWS_AS(volume::voxel_cuboids(g, std::numeric_limits<float>::infinity()), Error);
    DensityGrid nan_grid = g;
    nan_grid.values[100] = std::nanf("");
    CHECK_THROWS_WITH(volume::voxel_cuboids(nan_grid), Catch::Contains("voxel 100") && Catch::Contains("NaN"));
    DensityGrid empty{{0, 4, 4}, vec3(1.0f), {}};
    CHECK_THROWS_AS(volume::voxel_cuboids(empty), Error);
    CHECK_THROWS_AS(volume::gradients(empty), Error);
    DensityGrid short_grid{{4, 4, 4}, vec3(1.0f), std::vector<float>(63)};
    CHECK_THROWS_WITH(volume::voxel_cuboids(short_grid), Catch::Contains("63 values"));
    CHECK_THROWS_AS(volume::gradient_at(short_grid, 0, 0, 0), Error);
    CHECK_THROWS_AS(volume::gradient_at(g, 6, 0, 0), Error);
    DensityGrid absurd{{1u << 30, 1u << 30, 1u << 30}, vec3(1.0f), {}};
    CHECK_THROWS_AS(volume::voxel_cuboids(absurd), Error);
}
