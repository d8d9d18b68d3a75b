// Value ranges (issue 10): auto/type/explicit, constant volumes, NRRD min/max, and the 12-bit CT
// stored in uint16 that the type range hides from the default threshold.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <sylva/volume/classify.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/value_range.hpp>
#include <sylva/volume/voxels.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;
using volume_test::as_bytes;
using volume_test::TempDir;
using volume_test::write_file;

namespace {

template <class T>
Volume volume_of(ScalarType type, const std::vector<T>& values) {
    Volume v;
    v.type = type;
    v.dims = Dims(static_cast<std::uint32_t>(values.size()), 1, 1);
    v.bytes.resize(values.size() * sizeof(T));
    std::memcpy(v.bytes.data(), values.data(), v.bytes.size());
    return v;
}

/// A 12-bit CT in uint16 as scanners write it: air 0..40, soft tissue ~1000, bone up to 3926.
std::vector<std::uint16_t> ct12(std::size_t n) {
    std::vector<std::uint16_t> v(n);
    for (std::size_t i = 0; i < n; ++i) {
        std::size_t k = i % 97;
        v[i] = static_cast<std::uint16_t>(k < 60 ? k % 41 : (k < 90 ? 900 + 7 * (k - 60) : 3926 - 3 * (96 - k)));
    }
    v[n / 2] = 3926;
    return v;
}

}  // namespace

TEST_CASE("ValueRange::parse reads auto, type and LO,HI and names what it refuses", "[range]") {
    CHECK(ValueRange::parse("auto").mode == ValueRange::Mode::Auto);
    CHECK(ValueRange::parse("type").mode == ValueRange::Mode::Type);
    ValueRange r = ValueRange::parse("-1000,3000");
    CHECK(r.mode == ValueRange::Mode::Explicit);
    CHECK(r.lo == -1000.0f);
    CHECK(r.hi == 3000.0f);
    ValueRange e = ValueRange::parse(" 1e-3 , +2.5 ");
    CHECK(e.lo == 1e-3f);
    CHECK(e.hi == 2.5f);
    CHECK(r.text() == "-1000,3000");
    ValueRange odd = ValueRange::between(1e-7f, 0.1f);  // round trips exactly
    CHECK(ValueRange::parse(odd.text()).lo == odd.lo);
    CHECK(ValueRange::parse(odd.text()).hi == odd.hi);
    CHECK(ValueRange::parse("auto").text() == "auto");
    for (const char* bad : {"", "Auto", "4095", "0,", ",1", "a,b", "0,1,2", "nan,1", "0,inf", "1e40,1e41"})
        CHECK_THROWS_WITH(ValueRange::parse(bad), Contains("is not auto, type or LO,HI") && Contains(bad));
    CHECK_THROWS_WITH(ValueRange::parse("5,1"), Contains("LO must be below HI"));
    CHECK_THROWS_WITH(ValueRange::parse("2,2"), Contains("LO must be below HI"));
    CHECK_THROWS_WITH(ValueRange::between(1.0f, std::numeric_limits<float>::quiet_NaN()), Contains("finite LO < HI"));
}

TEST_CASE("choose_range: auto takes the data's min/max, type the type's, explicit what it is given", "[range]") {
    Volume u16 = volume_of<std::uint16_t>(ScalarType::U16, {12, 3926, 400, 7});
    auto [r, s] = choose_range(u16, ValueRange::automatic());
    CHECK(r == std::pair{7.0f, 3926.0f});
    CHECK(s == RangeSource::Data);
    CHECK(choose_range(u16, ValueRange::of_type()).first == std::pair{0.0f, 65535.0f});
    CHECK(choose_range(u16, ValueRange::of_type()).second == RangeSource::Type);
    CHECK(choose_range(u16, ValueRange::between(0.0f, 4095.0f)).first == std::pair{0.0f, 4095.0f});
    CHECK(choose_range(u16, ValueRange::between(0.0f, 4095.0f)).second == RangeSource::Explicit);

    Volume u8 = volume_of<std::uint8_t>(ScalarType::U8, {3, 200, 17});
    CHECK(choose_range(u8, {}).first == std::pair{3.0f, 200.0f});
    CHECK(choose_range(u8, ValueRange::of_type()).first == std::pair{0.0f, 255.0f});

    Volume f = volume_of<float>(ScalarType::F32, {-1.0f, 0.25f, 1.0f, -0.5f});
    CHECK(choose_range(f, {}).first == std::pair{-1.0f, 1.0f});
    CHECK(choose_range(f, ValueRange::of_type()).first == std::pair{-1.0f, 1.0f});  // float32: no type range
    CHECK(choose_range(f, ValueRange::of_type()).second == RangeSource::Data);
    Volume big = volume_of<float>(ScalarType::F32, {0.0f, 1e6f, 5e5f});
    CHECK(choose_range(big, {}).first == std::pair{0.0f, 1e6f});

    // A hand-made explicit range is checked too.
    ValueRange inverted{ValueRange::Mode::Explicit, 5.0f, 1.0f};
    CHECK_THROWS_WITH(choose_range(u16, inverted), Contains("explicit value range") && Contains("LO < HI"));
}

TEST_CASE("normalize over the applied range: explicit ranges clamp, negative floats map to [0, 1]", "[range]") {
    Volume f = volume_of<float>(ScalarType::F32, {-1.0f, 0.0f, 0.5f, 1.0f});
    apply_value_range(f, {});
    DensityGrid g = normalize(f);
    CHECK(g.values == std::vector<float>{0.0f, 0.5f, 0.75f, 1.0f});
    apply_value_range(f, ValueRange::between(0.0f, 0.5f));
    CHECK(f.range_source == RangeSource::Explicit);
    CHECK(normalize(f).values == std::vector<float>{0.0f, 0.0f, 1.0f, 1.0f});
}

TEST_CASE("constant volumes: auto widens the one value to include 0", "[range]") {
    auto range_of = [](std::vector<float> v) { return choose_range(volume_of<float>(ScalarType::F32, v), {}); };
    CHECK(range_of({5.0f, 5.0f}).first == std::pair{0.0f, 5.0f});
    CHECK(range_of({5.0f, 5.0f}).second == RangeSource::Constant);
    CHECK(range_of({-3.0f}).first == std::pair{-3.0f, 0.0f});
    CHECK(range_of({0.0f, 0.0f}).first == std::pair{0.0f, 1.0f});
    Volume full = volume_of<std::uint8_t>(ScalarType::U8, {255, 255, 255});
    apply_value_range(full, {});
    CHECK(normalize(full).values == std::vector<float>{1.0f, 1.0f, 1.0f});  // fully dense, as with the type range
    Volume empty = volume_of<std::uint16_t>(ScalarType::U16, {0, 0});
    apply_value_range(empty, {});
    CHECK(normalize(empty).values == std::vector<float>{0.0f, 0.0f});
}

TEST_CASE("bad volumes: NaN, infinity and no voxels are named", "[range][errors]") {
    Volume nan = volume_of<float>(ScalarType::F32, {0.0f, std::numeric_limits<float>::quiet_NaN()});
    CHECK_THROWS_WITH(choose_range(nan, {}, "my volume"), Contains("my volume: float32 voxel 1 is NaN"));
    Volume inf = volume_of<float>(ScalarType::F32, {std::numeric_limits<float>::infinity()});
    CHECK_THROWS_WITH(choose_range(inf, ValueRange::of_type()), Contains("voxel 0 is infinite"));
    Volume none;
    none.type = ScalarType::U16;
    CHECK_THROWS_WITH(choose_range(none, {}), Contains("no voxels"));
    Volume odd = volume_of<std::uint8_t>(ScalarType::U8, {1, 2, 3});
    odd.type = ScalarType::U16;  // 3 bytes are not whole uint16 voxels
    CHECK_THROWS_WITH(choose_range(odd, {}), Contains("not whole uint16 voxels"));
}

TEST_CASE("a stated range wins over the data's in auto mode, one end alone takes the other from the data", "[range]") {
    Volume v = volume_of<std::uint16_t>(ScalarType::U16, {10, 3000});
    v.stated_range = std::pair{0.0f, 4095.0f};
    CHECK(choose_range(v, {}).first == std::pair{0.0f, 4095.0f});
    CHECK(choose_range(v, {}).second == RangeSource::Stated);
    CHECK(choose_range(v, ValueRange::of_type()).first == std::pair{0.0f, 65535.0f});
    CHECK(choose_range(v, ValueRange::between(1.0f, 2.0f)).first == std::pair{1.0f, 2.0f});
    v.stated_range = std::pair{std::numeric_limits<float>::quiet_NaN(), 4095.0f};
    CHECK(choose_range(v, {}).first == std::pair{10.0f, 4095.0f});
    v.stated_range = std::pair{0.0f, std::numeric_limits<float>::quiet_NaN()};
    CHECK(choose_range(v, {}).first == std::pair{0.0f, 3000.0f});
    v.stated_range = std::pair{5000.0f, std::numeric_limits<float>::quiet_NaN()};  // above the data's max
    CHECK_THROWS_WITH(choose_range(v, {}), Contains("stated value range"));
}

TEST_CASE("NRRD min/max fields are the stated range, bad ones are refused with their line", "[range][nrrd]") {
    TempDir dir;
    std::vector<std::uint16_t> data = ct12(24);
    auto nrrd = [&](const std::string& extra) {
        write_file(dir / "ct.nrrd", "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: little\n" +
                                        extra + "\n" + as_bytes(data));
        return dir / "ct.nrrd";
    };
    Volume plain = read_nrrd(nrrd(""));
    CHECK(plain.range_lo == 0.0f);
    CHECK(plain.range_hi == 3926.0f);
    CHECK(plain.range_source == RangeSource::Data);
    CHECK_FALSE(plain.stated_range);

    Volume stated = read_nrrd(nrrd("min: 0\nmax: 4095\nold min: -1024\nold max: 3071\n"));
    CHECK(stated.range_lo == 0.0f);
    CHECK(stated.range_hi == 4095.0f);
    CHECK(stated.range_source == RangeSource::Stated);
    CHECK(read_volume(nrrd("min: 0\nmax: 4095\n"), std::nullopt, ValueRange::of_type()).range_hi == 65535.0f);
    CHECK(read_volume(nrrd("max: 4095\n")).range_hi == 4095.0f);

    CHECK_THROWS_WITH(read_nrrd(nrrd("min: zero\n")), Contains("ct.nrrd: line 7") && Contains("'min") &&
                                                          Contains("not a finite number"));
    CHECK_THROWS_WITH(read_nrrd(nrrd("max: nan\n")), Contains("'max") && Contains("not a finite number"));
    CHECK_THROWS_WITH(read_nrrd(nrrd("max: 1e39\n")), Contains("not a finite number"));
    CHECK_THROWS_WITH(read_nrrd(nrrd("min: 100\nmax: 100\n")), Contains("must be above min"));
    CHECK_THROWS_WITH(read_nrrd(nrrd("min: 1\nmin: 2\n")), Contains("already given"));
}

TEST_CASE("a 12-bit CT in uint16: the default range shows it, the type range hides it", "[range]") {
    TempDir dir;
    std::vector<std::uint16_t> data = ct12(16 * 16 * 16);
    write_file(dir / "ct_16x16x16_uint16.raw", data);
    std::size_t expected = 0;  // voxels at >= 0.1 of the data's max (3926), counted on the raw values
    for (std::uint16_t x : data) expected += static_cast<float>(x) * (1.0f / 3926.0f) >= 0.1f ? 1u : 0u;
    REQUIRE(expected > 1000);

    Volume v = read_volume(dir / "ct_16x16x16_uint16.raw");
    CHECK(v.range_lo == 0.0f);
    CHECK(v.range_hi == 3926.0f);
    DensityGrid g = normalize(v);
    CHECK(voxel_cuboids(g, 0.1f).size() == expected);
    CHECK(count_classified(g, DensityThreshold{0.1f}) == expected);

    DensityGrid typed = normalize(read_volume(dir / "ct_16x16x16_uint16.raw", std::nullopt, ValueRange::of_type()));
    CHECK(voxel_cuboids(typed, 0.1f).empty());  // 3926 / 65535 = 0.06: the "nothing to build"
}

TEST_CASE("finite float32 voxels near +-FLT_MAX: a range too wide for float32 is refused for that reason",
          "[range][errors]") {
    const float big = 3.4e38f;
    Volume v = volume_of(ScalarType::F32, std::vector<float>{-big, 0.0f, big});
    // The data's range [-3.4e38, 3.4e38] is finite, but hi - lo overflows float32: no density
    // can be computed from it. Refused naming that, not as a NaN or non-finite voxel.
    CHECK_THROWS_WITH(apply_value_range(v, ValueRange{}, "v"),
                      Contains("v:") && Contains("too wide") && !Contains("NaN") && !Contains("not a finite"));
    // An explicit range the voxels fit: accepted, and the extremes clamp to 0 and 1.
    apply_value_range(v, ValueRange::between(-1.0f, 1.0f), "v");
    DensityGrid g = normalize(v);
    CHECK(g.values == std::vector<float>{0.0f, 0.5f, 1.0f});
    // One-sided voxels of the same size are fine: the span fits.
    Volume one = volume_of(ScalarType::F32, std::vector<float>{0.0f, big});
    apply_value_range(one, ValueRange{}, "one");
    CHECK(normalize(one).values == std::vector<float>{0.0f, 1.0f});
}
