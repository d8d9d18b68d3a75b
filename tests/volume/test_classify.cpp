// Classification: the classifier concept, thresholds and transfer-function alpha against brute
// force, and the BIH element counts of Kinkelin's Tables 3 and 6 on the real volumes.
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>

#include <sylva/volume/classify.hpp>
#include <sylva/volume/read.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;

namespace {
struct TakesString {
    bool operator()(const std::string&) const { return true; }
};
struct ReturnsNothing {
    void operator()(float) const {}
};
}  // namespace

static_assert(VoxelClassifier<DensityThreshold>);
static_assert(VoxelClassifier<TransferFunctionAlpha>);
static_assert(VoxelClassifier<bool (*)(float)>);
static_assert(VoxelClassifier<decltype([](float d) { return d > 0.5f; })>);
static_assert(!VoxelClassifier<TakesString>);
static_assert(!VoxelClassifier<ReturnsNothing>);
static_assert(!VoxelClassifier<int>);

namespace {
/// Densities i / 255 for i = 0 ... 255, each repeated `copies` times, in a 256 x copies x 1 grid.
DensityGrid every_uint8_density(std::uint32_t copies) {
    DensityGrid g{Dims(256, copies, 1), vec3(1.0f), {}};
    for (std::uint32_t c = 0; c < copies; ++c)
        for (int i = 0; i < 256; ++i) g.values.push_back(float(i) * (1.0f / 255.0f));
    return g;
}
}  // namespace

TEST_CASE("density threshold: d >= min_density, counted like brute force", "[classify]") {
    DensityGrid g = every_uint8_density(3);
    // v / 255 >= 0.1  <=>  v >= 25.5  <=>  v in 26 ... 255: 230 values, 3 copies each.
    CHECK(count_classified(g, DensityThreshold{}) == 3 * 230);
    CHECK(count_classified(g, DensityThreshold{0.5f}) == 3 * 128);  // v >= 127.5: 128 ... 255
    CHECK(count_classified(g, DensityThreshold{0.0f}) == 3 * 256);
    CHECK(count_classified(g, DensityThreshold{1.5f}) == 0);
    CHECK(count_classified(g, [](float d) { return d == 0.0f; }) == 3);
    g.values.pop_back();
    CHECK_THROWS_WITH(count_classified(g, DensityThreshold{}), Contains("767 values for 768 voxels"));
}

TEST_CASE("transfer-function alpha classifier: voxels with alpha > 0", "[classify]") {
    DensityGrid g = every_uint8_density(1);
    // Alpha is 0 up to 0.3 and rises after it: the uint8 densities above 0.3 are 77/255 ... 1.
    TransferFunctionAlpha above(TransferFunction::ramp(0.3f, 0.6f, vec4(1.0f)));
    CHECK(count_classified(g, above) == 256 - 77);
    // The CT preset is transparent up to the 0.1 noise threshold: every v >= 26 is visible,
    // every v <= 24 is not; v = 25 sits a rounding error above entry 25 (see classify.hpp).
    TransferFunctionAlpha ct(TransferFunction::ct_bone_tissue());
    for (std::uint32_t v = 0; v < 256; ++v)
        if (v != 25) CHECK(ct(g.at(v, 0, 0)) == (v >= 26));
    CHECK(ct.transfer_function().at(g.at(25, 0, 0)).a < 1e-8f);
    // A tolerance of 1e-6 drops that sliver: then exactly the voxels with d >= 0.1 remain.
    TransferFunctionAlpha ct_tol(TransferFunction::ct_bone_tissue(), 1e-6f);
    CHECK(count_classified(g, ct_tol) == count_classified(g, DensityThreshold{}));
    CHECK_THROWS_WITH(TransferFunctionAlpha(TransferFunction(), -0.5f), Contains("min_alpha"));
    TransferFunctionAlpha none(TransferFunction({{0.0f, vec4(1.0f, 1.0f, 1.0f, 0.0f)}}));
    CHECK(count_classified(g, none) == 0);
}

namespace {
/// Reads a data volume and checks the count of voxels with normalised density >= 0.1 through
/// the library (read_volume, normalize, count_classified) and by brute force over the raw bytes.
void check_element_count(const std::string& name, std::size_t paper_count, std::optional<vec3> spacing = {}) {
    auto path = volume_test::data_file(name);
    if (!path) return;
    Volume v = read_volume(*path, spacing);
    DensityGrid g = normalize(v);
    std::size_t brute = 0;
    for (std::byte b : v.bytes) brute += std::to_integer<int>(b) * 10 >= 255 ? 1u : 0u;  // v / 255 >= 0.1
    CHECK(brute == paper_count);
    CHECK(count_classified(g, DensityThreshold{}) == paper_count);
    CHECK(count_classified(g, TransferFunctionAlpha(TransferFunction::ct_bone_tissue(), 1e-6f)) == paper_count);
}
}  // namespace

TEST_CASE("voxels >= 0.1 are Kinkelin's BIH element counts (Tables 3 and 6)", "[classify][data]") {
    SECTION("lobster: 341,256") { check_element_count("lobster_301x324x56_uint8.raw", 341256, vec3(1.0f, 1.0f, 1.4f)); }
    SECTION("engine: 1,352,439") { check_element_count("engine_256x256x128_uint8.raw", 1352439); }
    SECTION("aneurism: 113,453") { check_element_count("aneurism_256x256x256_uint8.raw", 113453); }
}
