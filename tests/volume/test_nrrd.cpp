// NRRD: attached and detached data, gzip, byte order, spacing sources, conversions, and every
// malformed header or data case.
#include <catch2/catch.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <sylva/volume/nrrd.hpp>

#include "volume_test_util.hpp"

#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
#include <zlib.h>
#endif

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;
using volume_test::as_bytes;
using volume_test::TempDir;
using volume_test::write_file;

namespace {

/// 2 x 3 x 4 voxels valued 10 * i (uint8).
std::vector<std::uint8_t> ramp_u8() {
    std::vector<std::uint8_t> v(24);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::uint8_t>(10 * i);
    return v;
}

/// 2 x 3 x 4 uint16 voxels valued 1000 * i + 1, in the given byte order.
std::string ramp_u16(bool big) {
    std::string s;
    for (int i = 0; i < 24; ++i) {
        std::uint16_t x = static_cast<std::uint16_t>(1000 * i + 1);
        char lo = static_cast<char>(x & 0xFF), hi = static_cast<char>(x >> 8);
        s += big ? std::string{hi, lo} : std::string{lo, hi};
    }
    return s;
}

const std::string u8_header = "NRRD0004\n# a comment\ntype: uchar\ndimension: 3\nsizes: 2 3 4\nencoding: raw\n";

void check_ramp_u8(const Volume& v) {
    REQUIRE(v.type == ScalarType::U8);
    REQUIRE(v.dims == Dims(2, 3, 4));
    CHECK(v.range_lo == 0.0f);
    CHECK(v.range_hi == 230.0f);  // the data's max: no min/max in the header
    for (std::size_t i = 0; i < 24; ++i) CHECK(v.value(i) == float(10 * i));
}

#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
/// `data` as one gzip member (independent of the reader: deflate with a gzip wrapper).
std::string gzip(const std::string& data) {
    z_stream zs{};
    REQUIRE(deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) == Z_OK);
    std::string out(deflateBound(&zs, static_cast<uLong>(data.size())) + 64, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
    zs.avail_in = static_cast<uInt>(data.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    REQUIRE(deflate(&zs, Z_FINISH) == Z_STREAM_END);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

/// `data` as a zlib stream (deflate with the zlib wrapper, not gzip's).
std::string zlib(const std::string& data) {
    uLongf n = compressBound(static_cast<uLong>(data.size()));
    std::string out(n, '\0');
    REQUIRE(compress(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(data.data()),
                     static_cast<uLong>(data.size())) == Z_OK);
    out.resize(n);
    return out;
}
#endif

}  // namespace

TEST_CASE("NRRD with attached raw data, spacings, comments and key/value pairs", "[nrrd]") {
    TempDir dir;
    write_file(dir / "a.nrrd", u8_header +
                                   "spacings: 0.5 1 1.4\nkinds: domain domain domain\nspace origin: (1,2,3)\n"
                                   "unknownfield: whatever\nmodality:=CT\n\n" +
                                   as_bytes(ramp_u8()));
    Volume v = read_nrrd(dir / "a.nrrd");
    check_ramp_u8(v);
    CHECK(v.spacing == vec3(0.5f, 1.0f, 1.4f));
    SECTION("spacings at the ends of the float range are kept") {
        write_file(dir / "c.nrrd", u8_header + "spacings: 3e38 1.2e-38 1\n\n" + as_bytes(ramp_u8()));
        CHECK(read_nrrd(dir / "c.nrrd").spacing == vec3(3e38f, 1.2e-38f, 1.0f));
    }
    SECTION("CRLF header lines and every version of the magic") {
        for (char version : std::string("12345")) {
            std::string h = std::string("NRRD000") + version +
                            "\r\ntype: uint8\r\ndimension: 3\r\nsizes: 2 3 4\r\nencoding: raw\r\n\r\n";
            write_file(dir / "b.nrrd", h + as_bytes(ramp_u8()));
            check_ramp_u8(read_nrrd(dir / "b.nrrd"));
            CHECK(read_nrrd(dir / "b.nrrd").spacing == vec3(1.0f));
        }
    }
}

TEST_CASE("NRRD uint16 in both byte orders", "[nrrd]") {
    TempDir dir;
    for (bool big : {false, true}) {
        std::string h = "NRRD0005\ntype: unsigned short\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: " +
                        std::string(big ? "big" : "little") + "\n\n";
        write_file(dir / "u16.nrrd", h + ramp_u16(big));
        Volume v = read_nrrd(dir / "u16.nrrd");
        REQUIRE(v.type == ScalarType::U16);
        CHECK(v.range_lo == 1.0f);
        CHECK(v.range_hi == 23001.0f);
        CHECK(read_nrrd(dir / "u16.nrrd", ValueRange::of_type()).range_hi == 65535.0f);
        for (std::size_t i = 0; i < 24; ++i) CHECK(v.value(i) == float(1000 * i + 1));
    }
}

TEST_CASE("NRRD float, and types converted to float32", "[nrrd]") {
    TempDir dir;
    SECTION("big-endian float, range = data min/max") {
        std::string data;
        for (int i = 0; i < 24; ++i) {
            float f = -2.0f + 0.5f * float(i);
            std::uint32_t w;
            std::memcpy(&w, &f, 4);
            for (int b = 3; b >= 0; --b) data.push_back(static_cast<char>((w >> (8 * b)) & 0xFF));
        }
        write_file(dir / "f.nrrd",
                   "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: big\n\n" + data);
        Volume v = read_nrrd(dir / "f.nrrd");
        REQUIRE(v.type == ScalarType::F32);
        CHECK(v.range_lo == -2.0f);
        CHECK(v.range_hi == 9.5f);
        CHECK(v.value(5) == 0.5f);
    }
    SECTION("short (CT Hounsfield units) becomes float32") {
        std::vector<std::int16_t> s(24);
        for (int i = 0; i < 24; ++i) s[i] = static_cast<std::int16_t>(-1000 + 100 * i);
        write_file(
            dir / "s.nrrd",
            "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: little\n\n" + as_bytes(s));
        Volume v = read_nrrd(dir / "s.nrrd");
        REQUIRE(v.type == ScalarType::F32);
        CHECK(v.value(0) == -1000.0f);
        CHECK(v.value(23) == 1300.0f);
        CHECK(v.range_lo == -1000.0f);
        CHECK(v.range_hi == 1300.0f);
    }
    SECTION("double becomes float32") {
        std::vector<double> d(24, 0.25);
        d[3] = 4.0;
        write_file(
            dir / "d.nrrd",
            "NRRD0004\ntype: double\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: little\n\n" + as_bytes(d));
        Volume v = read_nrrd(dir / "d.nrrd");
        CHECK(v.value(3) == 4.0f);
        CHECK(v.range_lo == 0.25f);
    }
    SECTION("NaN float voxels are an error with the index") {
        std::vector<float> f(24, 1.0f);
        f[17] = std::numeric_limits<float>::quiet_NaN();
        write_file(
            dir / "n.nrrd",
            "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: little\n\n" + as_bytes(f));
        CHECK_THROWS_WITH(read_nrrd(dir / "n.nrrd"), Contains("voxel 17") && Contains("NaN") && Contains("n.nrrd"));
    }
}

TEST_CASE("NRRD spacing from space directions, and 4-D with a leading size 1", "[nrrd]") {
    TempDir dir;
    SECTION("diagonal space directions, flips ignored") {
        write_file(dir / "d.nrrd",
                   u8_header + "space: left-posterior-superior\nspace directions: (-0.5,0,0) (0,2,0) (0,0,1.25)\n\n" +
                       as_bytes(ramp_u8()));
        Volume v = read_nrrd(dir / "d.nrrd");
        check_ramp_u8(v);
        CHECK(v.spacing == vec3(0.5f, 2.0f, 1.25f));
    }
    SECTION("4-D with a leading size 1 and 'none' for its direction") {
        write_file(dir / "e.nrrd",
                   "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 1 2 3 4\nencoding: raw\n"
                   "space dimension: 3\nspace directions: none (3,0,0) (0,3,0) (0,0,3)\n\n" +
                       as_bytes(ramp_u8()));
        Volume v = read_nrrd(dir / "e.nrrd");
        check_ramp_u8(v);
        CHECK(v.spacing == vec3(3.0f));
        write_file(dir / "f.nrrd",
                   "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 1 2 3 4\nencoding: raw\nspacings: nan 1 2 3\n\n" +
                       as_bytes(ramp_u8()));
        CHECK(read_nrrd(dir / "f.nrrd").spacing == vec3(1.0f, 2.0f, 3.0f));
    }
    SECTION("spacings agreeing with space directions are fine; disagreeing ones are not") {
        write_file(dir / "g.nrrd",
                   u8_header + "spacings: 1 2 3\nspace directions: (1,0,0) (0,2,0) (0,0,3)\n\n" + as_bytes(ramp_u8()));
        CHECK(read_nrrd(dir / "g.nrrd").spacing == vec3(1.0f, 2.0f, 3.0f));
        write_file(dir / "h.nrrd",
                   u8_header + "spacings: 1 2 3\nspace directions: (1,0,0) (0,2,0) (0,0,4)\n\n" + as_bytes(ramp_u8()));
        CHECK_THROWS_WITH(read_nrrd(dir / "h.nrrd"), Contains("disagree"));
    }
}

TEST_CASE("NRRD detached data (.nhdr) relative to the header's folder, with skips", "[nrrd]") {
    TempDir dir;
    write_file(dir / "data" / "vol.raw", as_bytes(ramp_u8()));
    write_file(dir / "vol.nhdr", u8_header + "data file: data/vol.raw\n");
    check_ramp_u8(read_nrrd(dir / "vol.nhdr"));
    write_file(dir / "vol2.nhdr", u8_header + "datafile: ./data/vol.raw\n\n");  // old spelling, blank line
    check_ramp_u8(read_nrrd(dir / "vol2.nhdr"));
    write_file(dir / "abs.nhdr", u8_header + "data file: " + (dir / "data" / "vol.raw").string() + "\n");
    check_ramp_u8(read_nrrd(dir / "abs.nhdr"));
    SECTION("line skip and byte skip") {
        write_file(dir / "skip.raw", "first line\nsecond\nXYZ" + as_bytes(ramp_u8()));
        write_file(dir / "skip.nhdr", u8_header + "data file: skip.raw\nline skip: 2\nbyte skip: 3\n");
        check_ramp_u8(read_nrrd(dir / "skip.nhdr"));
        write_file(dir / "tail.raw", "some preamble of any length" + as_bytes(ramp_u8()));
        write_file(dir / "tail.nhdr", u8_header + "data file: tail.raw\nbyte skip: -1\n");
        check_ramp_u8(read_nrrd(dir / "tail.nhdr"));
    }
    SECTION("errors") {
        write_file(dir / "missing.nhdr", u8_header + "data file: nowhere.raw\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "missing.nhdr"),
                          Contains("nowhere.raw") && Contains("cannot open the data file"));
        write_file(dir / "list.nhdr", u8_header + "data file: LIST\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "list.nhdr"), Contains("single data file"));
        write_file(dir / "fmt.nhdr", u8_header + "data file: slice%03d.raw 1 4 1\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "fmt.nhdr"), Contains("single data file"));
        write_file(dir / "nodata.nhdr", u8_header);
        CHECK_THROWS_WITH(read_nrrd(dir / "nodata.nhdr"), Contains("no data"));
        write_file(dir / "short.raw", "x\n");
        write_file(dir / "lines.nhdr", u8_header + "data file: short.raw\nline skip: 5\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "lines.nhdr"), Contains("skipped lines"));
        write_file(dir / "neg.nhdr", u8_header + "data file: data/vol.raw\nbyte skip: -2\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "neg.nhdr"), Contains("byte skip") && Contains(">= -1"));
    }
}

TEST_CASE("NRRD data of the wrong size", "[nrrd][errors]") {
    TempDir dir;
    std::string data = as_bytes(ramp_u8());
    write_file(dir / "t.nrrd", u8_header + "\n" + data.substr(0, 20));
    CHECK_THROWS_WITH(read_nrrd(dir / "t.nrrd"),
                      Contains("20 bytes") && Contains("asks for 24") && Contains("truncated"));
    write_file(dir / "b.nrrd", u8_header + "\n" + data + "extra");
    CHECK_THROWS_WITH(read_nrrd(dir / "b.nrrd"), Contains("29 bytes") && Contains("too big"));
    write_file(dir / "s.nrrd", u8_header + "byte skip: 30\n\n" + data);
    CHECK_THROWS_WITH(read_nrrd(dir / "s.nrrd"), Contains("truncated"));
    write_file(dir / "m.nrrd", u8_header + "byte skip: -1\n\n" + data.substr(0, 10));
    CHECK_THROWS_WITH(read_nrrd(dir / "m.nrrd"), Contains("truncated"));
    write_file(dir / "o.nrrd",
               "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4294967295 4294967295 16\nencoding: raw\n\n");
    CHECK_THROWS_WITH(read_nrrd(dir / "o.nrrd"), Contains("overflow"));
}

TEST_CASE("malformed NRRD headers are errors that name the problem", "[nrrd][errors]") {
    TempDir dir;
    std::string data = as_bytes(ramp_u8());
    auto fails_with = [&](const std::string& file_text, const std::string& what) {
        write_file(dir / "bad.nrrd", file_text);
        CHECK_THROWS_WITH(read_nrrd(dir / "bad.nrrd"), Contains(what) && Contains("bad.nrrd"));
    };
    const std::string tail = "encoding: raw\n\n" + data;
    fails_with("", "empty file");
    fails_with("P5\n2 3\n255\n", "not a NRRD file");
    fails_with("NRRD0009\n", "newer than 5");
    fails_with(std::string(100000, 'x'), "longer than 64 KiB");
    fails_with("NRRD0004\ndimension: 3\nsizes: 2 3 4\n" + tail, "missing field 'type'");
    fails_with("NRRD0004\ntype: uchar\nsizes: 2 3 4\n" + tail, "missing field 'dimension'");
    fails_with("NRRD0004\ntype: uchar\ndimension: 3\n" + tail, "missing field 'sizes'");
    fails_with("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3 4\n\n" + data, "missing field 'encoding'");
    fails_with("NRRD0004\ntype: ushort\ndimension: 3\nsizes: 2 3 2\n" + tail, "missing field 'endian'");
    fails_with("NRRD0004\ntype: ushort\ndimension: 3\nsizes: 2 3 2\nendian: middle\n" + tail, "'little' or 'big'");
    fails_with("NRRD0004\ntype: int64\ndimension: 3\nsizes: 2 3 4\n" + tail, "unsupported voxel type");
    fails_with("NRRD0004\ntype: block\nblock size: 4\ndimension: 3\nsizes: 2 3 4\n" + tail, "line 2");
    fails_with("NRRD0004\ntype: uchar\ndimension: 2\nsizes: 6 4\n" + tail, "only 3, or 4");
    fails_with("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3\n" + tail, "2 sizes for dimension 3");
    fails_with("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 0 4\n" + tail, "'0' is not a size");
    fails_with("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 three 4\n" + tail, "'three' is not a size");
    fails_with("NRRD0004\ntype: uchar\ndimension: 4\nsizes: 3 2 3 4\n" + tail, "leading size 1");
    fails_with(u8_header.substr(0, u8_header.size() - 14) + "encoding: ascii\n\n1 2 3", "unsupported encoding");
    fails_with(u8_header.substr(0, u8_header.size() - 14) + "encoding: bzip2\n\n" + data, "unsupported encoding");
    fails_with(u8_header + "space directions: (1,0.5,0) (0,1,0) (0,0,1)\n\n" + data, "only diagonal directions");
    fails_with(u8_header + "space directions: (0,1,0) (1,0,0) (0,0,1)\n\n" + data, "only diagonal directions");
    fails_with(u8_header + "space directions: (1,0,0) (0,1,0)\n\n" + data, "2 entries for 3 axes");
    fails_with(u8_header + "space directions: (1,0) (0,1) (0,0)\n\n" + data, "3-D space vectors");
    fails_with(u8_header + "space directions: (1,0,0) (0,0,0) (0,0,1)\n\n" + data, "zero length");
    fails_with(u8_header + "space directions: (1,0,0 (0,1,0) (0,0,1)\n\n" + data, "space directions");
    fails_with(u8_header + "spacings: 1 -2 1\n\n" + data, "finite positive spacing");
    fails_with(u8_header + "spacings: 1 1\n\n" + data, "2 values for 3 axes");
    fails_with(u8_header + "spacings: 1 nan 1\n\n" + data, "finite positive spacing");
    // Finite as doubles, but infinite or zero as floats (fuzz_regressions/nrrd_attached/spacing_past_float).
    fails_with(u8_header + "spacings: 1 1 1e39\n\n" + data, "finite positive spacing");
    fails_with(u8_header + "spacings: 1 1e-39 1\n\n" + data, "finite positive spacing");
    fails_with(u8_header + "spacings: 1e-50 1 1\n\n" + data, "finite positive spacing");
    fails_with(u8_header + "space directions: (1,0,0) (0,4e38,0) (0,0,1)\n\n" + data, "length outside");
    fails_with(u8_header + "space directions: (1,0,0) (0,1,0) (0,0,1e-40)\n\n" + data, "length outside");
    fails_with(u8_header + "type: uchar\n\n" + data, "already given on line 3");
    fails_with(u8_header + "this line has no colon\n\n" + data, "line 7");
    fails_with(u8_header + "nospace:value\n\n" + data, "is not 'field: value'");
}

#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
TEST_CASE("NRRD gzip data, attached and detached, and broken streams", "[nrrd][gzip]") {
    TempDir dir;
    std::string data = as_bytes(ramp_u8());
    std::string header = u8_header.substr(0, u8_header.size() - 14);  // without "encoding: raw\n"
    write_file(dir / "g.nrrd", header + "encoding: gzip\n\n" + gzip(data));
    check_ramp_u8(read_nrrd(dir / "g.nrrd"));
    write_file(dir / "g.raw.gz", gzip(data));
    write_file(dir / "g.nhdr", header + "encoding: gz\ndata file: g.raw.gz\n");
    check_ramp_u8(read_nrrd(dir / "g.nhdr"));
    SECTION("byte skip counts decompressed bytes") {
        write_file(dir / "s.nrrd", header + "encoding: gzip\nbyte skip: 5\n\n" + gzip("12345" + data));
        check_ramp_u8(read_nrrd(dir / "s.nrrd"));
        write_file(dir / "s1.nrrd", header + "encoding: gzip\nbyte skip: -1\n\n" + gzip(data));
        CHECK_THROWS_WITH(read_nrrd(dir / "s1.nrrd"), Contains("only with raw"));
    }
    SECTION("big-endian uint16 through gzip") {
        write_file(dir / "u.nrrd",
                   "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 3 4\nendian: big\nencoding: gzip\n\n" +
                       gzip(ramp_u16(true)));
        Volume v = read_nrrd(dir / "u.nrrd");
        for (std::size_t i = 0; i < 24; ++i) CHECK(v.value(i) == float(1000 * i + 1));
    }
    SECTION("a larger volume than one inflate chunk") {
        std::vector<std::uint8_t> big(100 * 90 * 80);
        for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<std::uint8_t>((i * 7919) >> 5);
        write_file(dir / "big.nrrd",
                   "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100 90 80\nencoding: gzip\n\n" + gzip(as_bytes(big)));
        Volume v = read_nrrd(dir / "big.nrrd");
        REQUIRE(v.voxels() == big.size());
        CHECK(std::memcmp(v.bytes.data(), big.data(), big.size()) == 0);
    }
    SECTION("errors") {
        std::string z = gzip(data);
        write_file(dir / "cut.nrrd", header + "encoding: gzip\n\n" + z.substr(0, z.size() / 2));
        CHECK_THROWS_WITH(read_nrrd(dir / "cut.nrrd"), Contains("cut off") && Contains("truncated"));
        write_file(dir / "notrailer.nrrd", header + "encoding: gzip\n\n" + z.substr(0, z.size() - 4));
        CHECK_THROWS_WITH(read_nrrd(dir / "notrailer.nrrd"), Contains("truncated"));
        std::string corrupt = z;
        corrupt[corrupt.size() - 6] = static_cast<char>(corrupt[corrupt.size() - 6] ^ 0x55);  // inside the CRC
        write_file(dir / "crc.nrrd", header + "encoding: gzip\n\n" + corrupt);
        CHECK_THROWS_WITH(read_nrrd(dir / "crc.nrrd"), Contains("corrupt gzip data"));
        write_file(dir / "junk.nrrd", header + "encoding: gzip\n\nthis is not gzip data at all");
        CHECK_THROWS_WITH(read_nrrd(dir / "junk.nrrd"), Contains("corrupt gzip data"));
        write_file(dir / "short.nrrd", header + "encoding: gzip\n\n" + gzip(data.substr(0, 23)));
        CHECK_THROWS_WITH(read_nrrd(dir / "short.nrrd"), Contains("only 23 bytes") && Contains("asks for 24"));
        write_file(dir / "long.nrrd", header + "encoding: gzip\n\n" + gzip(data + "more"));
        CHECK_THROWS_WITH(read_nrrd(dir / "long.nrrd"), Contains("more than the 24 bytes") && Contains("too big"));
        // A header claiming 60000^3 voxels over a tiny stream fails on the stream, quickly.
        write_file(dir / "huge.nrrd",
                   "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 60000 60000 60000\nencoding: gzip\n\n" + z);
        CHECK_THROWS_WITH(read_nrrd(dir / "huge.nrrd"), Contains("only 24 bytes") && Contains("216000000000000"));
        write_file(dir / "empty.nrrd", header + "encoding: gzip\n\n");
        CHECK_THROWS_WITH(read_nrrd(dir / "empty.nrrd"), Contains("cut off"));
    }
}

TEST_CASE("NRRD gzip: concatenated members are one stream (as gzip(1) reads them); trailing bytes and zlib streams are refused",
          "[nrrd][gzip]") {
    TempDir dir;
    std::string data = as_bytes(ramp_u8());
    std::string header = u8_header.substr(0, u8_header.size() - 14);  // without "encoding: raw\n"
    auto attached = [&](const std::string& name, const std::string& body) {
        write_file(dir / name, header + "encoding: gzip\n\n" + body);
        return dir / name;
    };
    // Two and three members holding the data between them, and an empty member at the end.
    check_ramp_u8(read_nrrd(attached("two.nrrd", gzip(data.substr(0, 10)) + gzip(data.substr(10)))));
    check_ramp_u8(read_nrrd(attached("three.nrrd", gzip(data.substr(0, 5)) + gzip(data.substr(5, 7)) + gzip(data.substr(12)))));
    check_ramp_u8(read_nrrd(attached("emptytail.nrrd", gzip(data) + gzip(""))));
    // A second member with more data: too big, like one long member.
    CHECK_THROWS_WITH(read_nrrd(attached("more.nrrd", gzip(data) + gzip("x"))),
                      Contains("more than the 24 bytes") && Contains("too big"));
    // Bytes after the last member that are no gzip member.
    CHECK_THROWS_WITH(read_nrrd(attached("junk.nrrd", gzip(data) + "extra")),
                      Contains("after the gzip data") && Contains("not a gzip member"));
    CHECK_THROWS_WITH(read_nrrd(attached("zeros.nrrd", gzip(data) + std::string(8, '\0'))), Contains("not a gzip member"));
    // zlib-wrapped deflate data are not gzip, whatever zlib could read.
    CHECK_THROWS_WITH(read_nrrd(attached("zlib.nrrd", zlib(data))), Contains("zlib") && Contains("not gzip"));
    // A directory named as the data file.
    std::filesystem::create_directory(dir / "adir.gz");
    write_file(dir / "dir.nhdr", header + "encoding: gzip\ndata file: adir.gz\n");
    CHECK_THROWS_WITH(read_nrrd(dir / "dir.nhdr"), Contains("is a directory") && !Contains("truncated"));
    write_file(dir / "rawdir.nhdr", header + "encoding: raw\ndata file: adir.gz\n");
    CHECK_THROWS_WITH(read_nrrd(dir / "rawdir.nhdr"), Contains("is a directory"));
}
#else
TEST_CASE("NRRD gzip without zlib is a clear error", "[nrrd][gzip]") {
    TempDir dir;
    write_file(dir / "g.nrrd", u8_header.substr(0, u8_header.size() - 14) + "encoding: gzip\n\n\x1f\x8b\x08");
    CHECK_THROWS_WITH(read_nrrd(dir / "g.nrrd"), Contains("gzip encoding needs zlib"));
}
#endif

TEST_CASE("NRRD header bytes: control characters are refused, and error messages never echo raw bytes", "[nrrd][errors]") {
    TempDir dir;
    std::string data = as_bytes(ramp_u8());
    write_file(dir / "g.raw", data);
    // A NUL inside the data file name used to cut the name silently at the NUL ("g.raw").
    write_file(dir / "nul.nhdr", u8_header + std::string("data file: g.raw\0junk\n", 22));
    CHECK_THROWS_WITH(read_nrrd(dir / "nul.nhdr"), Contains("line 7") && Contains("control character") && Contains("\\x00"));
    // A terminal escape sequence in a field: refused, and shown escaped.
    write_file(dir / "esc.nrrd", "NRRD0004\ntype: \x1b[31muchar\ndimension: 3\nsizes: 2 3 4\nencoding: raw\n\n" + data);
    CHECK_THROWS_WITH(read_nrrd(dir / "esc.nrrd"), Contains("\\x1b") && !Contains("\x1b"));
    // A binary first line: "not a NRRD file", escaped.
    write_file(dir / "bin.nrrd", std::string("\x1b]0;owned\x07\x01\xff\n", 12) + data);
    CHECK_THROWS_WITH(read_nrrd(dir / "bin.nrrd"),
                      Contains("not a NRRD file") && Contains("\\x1b") && !Contains("\x1b") && !Contains("\x07"));
    // A malformed line with a control byte: escaped in the message.
    write_file(dir / "bad.nrrd", u8_header + "what\x1b[2J\n\n" + data);
    CHECK_THROWS_WITH(read_nrrd(dir / "bad.nrrd"), !Contains("\x1b"));
}
