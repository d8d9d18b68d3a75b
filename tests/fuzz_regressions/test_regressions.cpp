// What each fuzz finding changed, checked on its committed input (tests/fuzz_regressions/TARGET/)
// and on the smallest case that shows it. Each of these failed before its fix.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/validate.hpp>
#include <sylva/volume/nrrd.hpp>

using namespace sylva;
using Catch::Matchers::Contains;

namespace {

std::vector<std::uint32_t> words_in(const std::string& name) {
    std::ifstream in(std::string(SYLVA_FUZZ_REGRESSIONS) + "/" + name, std::ios::binary);
    REQUIRE(in);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<std::uint32_t> w(bytes.size() / 4);
    std::memcpy(w.data(), bytes.data(), w.size() * 4);
    return w;
}

}  // namespace

TEST_CASE("lod/nan_root_box: bih::validate refuses a header whose root box is NaN", "[fuzz][bih][lod]") {
    // fuzz_lod: a LoD encoding with root_lo.x = NaN passed validate(); every decoded leaf box
    // became NaN, and encode_node_ranges converted NaN to uint32 (undefined behaviour).
    std::vector<std::uint32_t> w = words_in("lod/nan_root_box");
    REQUIRE(std::isnan(std::bit_cast<float>(w[8])));
    CHECK_THROWS_WITH(bih::validate(w), Contains("root box or traversal space"));
    CHECK_THROWS_WITH(bih::encode_node_ranges(w, vec3(1.0f)), Contains("root box or traversal space"));
    // The same refusal for each header float word (root box, traversal origin and scale).
    w[8] = std::bit_cast<std::uint32_t>(0.0f);
    REQUIRE_NOTHROW(bih::validate(w));
    for (std::uint32_t at = 8; at < 20; ++at)
        for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
            std::vector<std::uint32_t> m = w;
            m[at] = std::bit_cast<std::uint32_t>(at % 3 == 0 ? -bad : bad);
            INFO("word " << at << " = " << bad);
            CHECK_THROWS_WITH(bih::validate(m), Contains("root box or traversal space"));
        }
    std::vector<std::uint32_t> inverted = w;
    std::swap(inverted[9], inverted[12]);  // root_lo.y above root_hi.y
    CHECK_THROWS_WITH(bih::validate(inverted), Contains("axis 1"));
}

TEST_CASE("lod/nan_root_box: a NaN density bound becomes the widest node range, not a wrapped integer", "[fuzz][lod]") {
    // A flat leaf box with an infinite side (the +-inf planes of EmptyChildren::Infinite) gives
    // 0 * inf = NaN in the reconstructed range; the node range must then never cull.
    CHECK(bih::detail::unorm16_bound(std::numeric_limits<double>::quiet_NaN(), false) == 0u);
    CHECK(bih::detail::unorm16_bound(std::numeric_limits<double>::quiet_NaN(), true) == 65535u);
    CHECK(bih::detail::unorm16_bound(0.5, false) == 32767u);
    CHECK(bih::detail::unorm16_bound(0.5, true) == 32768u);
}

TEST_CASE("nrrd_attached/spacing_past_float: a spacing finite as a double but not as a float is refused",
          "[fuzz][nrrd]") {
    // fuzz_nrrd_attached (found by CI's 20-second fuzz run): "spacings: 1 1 444...442" (91
    // digits) passed the double's finite-and-positive check and became an infinite float
    // spacing (a double beyond the float range, converted: undefined behaviour); a tiny one
    // became 0. The spacings and space directions must now lie in the positive normal floats.
    CHECK_THROWS_WITH(volume::read_nrrd(std::string(SYLVA_FUZZ_REGRESSIONS) + "/nrrd_attached/spacing_past_float"),
                      Contains("not a finite positive spacing"));
}
