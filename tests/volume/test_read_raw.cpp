// Raw volumes: the name convention, round trips of every type, every error, and read_volume.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <sylva/volume/read.hpp>
#include <sylva/volume/read_raw.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;
using volume_test::TempDir;
using volume_test::write_file;

TEST_CASE("parse_raw_name reads NAME_XxYxZ_TYPE.raw", "[raw]") {
    RawInfo a = parse_raw_name("/work/shared/data/lobster_301x324x56_uint8.raw");
    CHECK(a.dims == Dims(301, 324, 56));
    CHECK(a.type == ScalarType::U8);
    CHECK(a.spacing == vec3(1.0f));
    RawInfo b = parse_raw_name("my_ct_scan_512x512x174_uint16.raw");  // underscores inside NAME
    CHECK(b.dims == Dims(512, 512, 174));
    CHECK(b.type == ScalarType::U16);
    RawInfo c = parse_raw_name("sim_4x5x6_float32.RAW");
    CHECK(c.dims == Dims(4, 5, 6));
    CHECK(c.type == ScalarType::F32);
    CHECK(parse_raw_name("4294967295x4294967295x16_uint8.raw").dims == Dims(4294967295u, 4294967295u, 16u));
}

TEST_CASE("parse_raw_name rejects names off the convention, saying why", "[raw][errors]") {
    CHECK_THROWS_WITH(parse_raw_name("vol_4x4x4_uint8.dat"), Contains("does not end in .raw"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4x4x4_int16.raw"),
                      Contains("unknown voxel type 'int16'") && Contains("uint8, uint16, float32"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4x4x4.raw"), Contains("unknown voxel type '4x4x4'"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4x4_uint8.raw"), Contains("dimensions '4x4'"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4xax4_uint8.raw"), Contains("dimensions '4xax4'"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4x4x4x4_uint8.raw"), Contains("dimensions"));
    CHECK_THROWS_WITH(parse_raw_name("vol_4294967296x1x1_uint8.raw"), Contains("below 2^32"));
    CHECK_THROWS_WITH(parse_raw_name("vol_-4x4x4_uint8.raw"), Contains("dimensions"));
    CHECK_THROWS_WITH(parse_raw_name("uint8.raw"), Contains("no _TYPE"));
    CHECK_THROWS_AS(parse_raw_name(".raw"), Error);
}

TEST_CASE("uint8, uint16 and float32 raw files read back exactly, x fastest", "[raw]") {
    TempDir dir;
    Dims dims(3, 2, 4);
    std::size_t n = 24;
    SECTION("uint8: the data's range by default, the full type range on request") {
        std::vector<std::uint8_t> v(n);
        for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>(i * 10);
        write_file(dir / "a_3x2x4_uint8.raw", v);
        Volume vol = read_raw(dir / "a_3x2x4_uint8.raw", parse_raw_name("a_3x2x4_uint8.raw"));
        CHECK(vol.type == ScalarType::U8);
        CHECK(vol.dims == dims);
        CHECK(vol.range_lo == 0.0f);
        CHECK(vol.range_hi == 230.0f);
        CHECK(vol.range_source == RangeSource::Data);
        auto view = vol.view<std::uint8_t>();
        CHECK(view.at(2, 1, 3) == v[2 + 3 * (1 + 2 * 3)]);
        CHECK(view.at(1, 0, 0) == 10);
        CHECK(normalize(vol).at(2, 1, 3) == Approx(1.0));
        Volume typed = read_raw(dir / "a_3x2x4_uint8.raw", parse_raw_name("a_3x2x4_uint8.raw"), ValueRange::of_type());
        CHECK(typed.range_hi == 255.0f);
        CHECK(typed.range_source == RangeSource::Type);
        CHECK(normalize(typed).at(2, 1, 3) == Approx(230.0 / 255.0));
    }
    SECTION("uint16: little-endian, the data's range or the full type range") {
        std::vector<std::uint8_t> le;
        for (std::size_t i = 0; i < n; ++i) {
            std::uint16_t x = static_cast<std::uint16_t>(1000 * i + 7);
            le.push_back(static_cast<std::uint8_t>(x & 0xFF));
            le.push_back(static_cast<std::uint8_t>(x >> 8));
        }
        write_file(dir / "b_3x2x4_uint16.raw", le);
        Volume vol = read_raw(dir / "b_3x2x4_uint16.raw", RawInfo{dims, ScalarType::U16, vec3(1.0f, 2.0f, 0.5f)});
        CHECK(vol.range_lo == 7.0f);
        CHECK(vol.range_hi == 23007.0f);
        CHECK(read_raw(dir / "b_3x2x4_uint16.raw", RawInfo{dims, ScalarType::U16, vec3(1.0f)}, ValueRange::of_type())
                  .range_hi == 65535.0f);
        CHECK(vol.spacing == vec3(1.0f, 2.0f, 0.5f));
        for (std::size_t i = 0; i < n; ++i) CHECK(vol.value(i) == float(1000 * i + 7));
    }
    SECTION("float32: value range is the data's min and max") {
        std::vector<float> v(n);
        for (std::size_t i = 0; i < n; ++i) v[i] = -3.5f + 0.25f * float(i);
        write_file(dir / "c_3x2x4_float32.raw", v);
        Volume vol = read_raw(dir / "c_3x2x4_float32.raw", parse_raw_name("c_3x2x4_float32.raw"));
        CHECK(vol.range_lo == -3.5f);
        CHECK(vol.range_hi == -3.5f + 0.25f * 23.0f);
        DensityGrid g = normalize(vol);
        CHECK(g.values.front() == 0.0f);
        CHECK(g.values.back() == 1.0f);
        CHECK(g.values[1] == Approx(1.0 / 23.0));
    }
}

TEST_CASE("raw reading errors name the file and the numbers", "[raw][errors]") {
    TempDir dir;
    std::vector<std::uint8_t> bytes(24, 7);
    write_file(dir / "v_3x2x4_uint8.raw", bytes);
    const RawInfo info{Dims(3, 2, 4), ScalarType::U8, vec3(1.0f)};
    SECTION("missing file") {
        CHECK_THROWS_WITH(read_raw(dir / "nope_3x2x4_uint8.raw", info),
                          Contains("nope_3x2x4_uint8.raw") && Contains("no such file"));
    }
    SECTION("a folder is not a file") { CHECK_THROWS_WITH(read_raw(dir.path(), info), Contains("no such file")); }
    SECTION("file too big") {
        CHECK_THROWS_WITH(
            read_raw(dir / "v_3x2x4_uint8.raw", RawInfo{Dims(3, 2, 3), ScalarType::U8, vec3(1.0f)}),
            Contains("24 bytes") && Contains("need 18 bytes") && Contains("too big") && Contains("v_3x2x4_uint8.raw"));
    }
    SECTION("file truncated") {
        write_file(dir / "t_3x2x4_uint16.raw", bytes);  // 24 bytes, 48 needed
        CHECK_THROWS_WITH(read_raw(dir / "t_3x2x4_uint16.raw", parse_raw_name("t_3x2x4_uint16.raw")),
                          Contains("24 bytes") && Contains("need 48 bytes") && Contains("truncated"));
    }
    SECTION("dimensions whose product overflows") {
        CHECK_THROWS_WITH(read_raw(dir / "v_3x2x4_uint8.raw", parse_raw_name("x_4294967295x4294967295x16_uint8.raw")),
                          Contains("overflow") && Contains("4294967295x4294967295x16"));
        CHECK_THROWS_WITH(read_raw(dir / "v_3x2x4_uint8.raw", parse_raw_name("x_4294967295x4294967295x1_float32.raw")),
                          Contains("overflow"));
    }
    SECTION("zero dimensions") {
        CHECK_THROWS_WITH(read_raw(dir / "v_3x2x4_uint8.raw", parse_raw_name("x_0x2x4_uint8.raw")),
                          Contains("zero extent"));
    }
    SECTION("unknown type") {
        CHECK_THROWS_WITH(
            read_raw(dir / "v_3x2x4_uint8.raw", RawInfo{Dims(3, 2, 4), static_cast<ScalarType>(9), vec3(1.0f)}),
            Contains("unknown voxel type"));
    }
    SECTION("bad spacing") {
        CHECK_THROWS_WITH(
            read_raw(dir / "v_3x2x4_uint8.raw", RawInfo{Dims(3, 2, 4), ScalarType::U8, vec3(1.0f, 0.0f, 1.0f)}),
            Contains("spacing"));
        CHECK_THROWS_WITH(read_raw(dir / "v_3x2x4_uint8.raw", RawInfo{Dims(3, 2, 4), ScalarType::U8,
                                                                      vec3(std::numeric_limits<float>::quiet_NaN())}),
                          Contains("spacing"));
    }
    SECTION("NaN and infinity in float32, with the voxel index") {
        std::vector<float> v(6, 1.0f);
        v[5] = std::numeric_limits<float>::quiet_NaN();
        write_file(dir / "n_3x2x1_float32.raw", v);
        CHECK_THROWS_WITH(read_raw(dir / "n_3x2x1_float32.raw", parse_raw_name("n_3x2x1_float32.raw")),
                          Contains("voxel 5") && Contains("NaN"));
        v[5] = 0.0f;
        v[2] = -std::numeric_limits<float>::infinity();
        write_file(dir / "i_3x2x1_float32.raw", v);
        CHECK_THROWS_WITH(read_raw(dir / "i_3x2x1_float32.raw", parse_raw_name("i_3x2x1_float32.raw")),
                          Contains("voxel 2") && Contains("infinite"));
    }
}

TEST_CASE("read_volume dispatches on the extension", "[raw][read]") {
    TempDir dir;
    std::vector<std::uint8_t> bytes(8, 200);
    write_file(dir / "v_2x2x2_uint8.raw", bytes);
    Volume a = read_volume(dir / "v_2x2x2_uint8.raw");
    CHECK(a.dims == Dims(2, 2, 2));
    CHECK(a.spacing == vec3(1.0f));
    Volume b = read_volume(dir / "v_2x2x2_uint8.raw", vec3(1.0f, 1.0f, 1.4f));
    CHECK(b.spacing == vec3(1.0f, 1.0f, 1.4f));
    write_file(dir / "v.nrrd",
               "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 1 1\nencoding: raw\nspacings: 2 3 4\n\n\x05\x06");
    Volume c = read_volume(dir / "v.nrrd");
    CHECK(c.spacing == vec3(2.0f, 3.0f, 4.0f));
    CHECK(c.value(1) == 6.0f);
    CHECK(read_volume(dir / "v.nrrd", vec3(0.5f)).spacing == vec3(0.5f));
    CHECK_THROWS_WITH(read_volume(dir / "v.vtk"), Contains("unknown extension '.vtk'") && Contains(".nrrd") &&
                                                      Contains(".nhdr") && Contains("NAME_XxYxZ_TYPE.raw"));
    CHECK_THROWS_WITH(read_volume(dir / "noextension"), Contains("unknown extension"));
    CHECK_THROWS_WITH(read_volume(dir / "v_2x2x2_uint8.raw", vec3(-1.0f)), Contains("spacing"));
    CHECK_THROWS_WITH(read_volume(dir / "v_2x2_uint8.raw"), Contains("NAME_XxYxZ_TYPE.raw"));
}
