// Transfer functions: table sampling and lookups against hand-computed values, the GPU packing,
// presets, and the text and JSON loaders (good and bad files).
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>

#include <sylva/volume/transfer_function.hpp>

#include "volume_test_util.hpp"

using namespace sylva;
using namespace sylva::volume;
using Catch::Matchers::Contains;
using volume_test::TempDir;
using volume_test::write_file;

namespace {
void check_rgba(vec4 got, vec4 want, double eps = 1e-6) {
    for (int c = 0; c < 4; ++c) CHECK(got[c] == Approx(want[c]).margin(eps));
}
/// Red and transparent at 0.2, blue and opaque at 0.6 (given out of order).
TransferFunction red_to_blue(std::size_t entries = 256) {
    return TransferFunction({{0.6f, {0.0f, 0.0f, 1.0f, 1.0f}}, {0.2f, {1.0f, 0.0f, 0.0f, 0.0f}}}, entries);
}
}  // namespace

TEST_CASE("entries sample the piecewise-linear curve at i / (N - 1), clamped outside", "[tf]") {
    TransferFunction tf = red_to_blue();
    REQUIRE(tf.size() == 256);
    CHECK(tf.points().front().density == 0.2f);  // sorted
    // Entry 102 sits at 102/255 = 0.4, halfway between the points.
    check_rgba(tf.entries()[102], {0.5f, 0.0f, 0.5f, 0.5f});
    // Entry 51 sits at 0.2 exactly; entry 52 at 52/255: (52/255 - 0.2) / 0.4 = 1/102 of the way.
    check_rgba(tf.entries()[51], {1.0f, 0.0f, 0.0f, 0.0f});
    check_rgba(tf.entries()[52], {1.0f - 1.0f / 102.0f, 0.0f, 1.0f / 102.0f, 1.0f / 102.0f});
    check_rgba(tf.entries()[0], {1.0f, 0.0f, 0.0f, 0.0f});    // below the first point
    check_rgba(tf.entries()[255], {0.0f, 0.0f, 1.0f, 1.0f});  // above the last
    check_rgba(tf.entries()[200], {0.0f, 0.0f, 1.0f, 1.0f});
}

TEST_CASE("at() interpolates linearly between entries, like the shader", "[tf]") {
    TransferFunction tf = red_to_blue();
    check_rgba(tf.at(0.4f), {0.5f, 0.0f, 0.5f, 0.5f});
    check_rgba(tf.at(0.1f), {1.0f, 0.0f, 0.0f, 0.0f});
    check_rgba(tf.at(0.9f), {0.0f, 0.0f, 1.0f, 1.0f});
    check_rgba(tf.at(-3.0f), {1.0f, 0.0f, 0.0f, 0.0f});
    check_rgba(tf.at(7.0f), {0.0f, 0.0f, 1.0f, 1.0f});
    check_rgba(tf.at(std::numeric_limits<float>::quiet_NaN()), {1.0f, 0.0f, 0.0f, 0.0f});
    // Halfway between entries 51 (alpha 0) and 52 (alpha 1/102): alpha 1/204.
    CHECK(tf.at(51.5f / 255.0f).a == Approx(1.0 / 204.0).margin(1e-6));
    // The curve's corner at 0.6 falls on entry 153, so the table is exact on both sides of it.
    CHECK(tf.at(152.5f / 255.0f).a == Approx((152.5 / 255.0 - 0.2) / 0.4).margin(1e-5));
    CHECK(tf.at(153.5f / 255.0f).a == Approx(1.0).margin(1e-6));
    SECTION("with more entries the lookup follows the curve more closely") {
        TransferFunction fine = red_to_blue(1024);
        CHECK(fine.size() == 1024);
        CHECK(fine.at(0.3f).a == Approx(0.25).margin(1e-5));
    }
    SECTION("a step: two points at one density, the later one wins there") {
        TransferFunction step({{0.0f, vec4(0.0f)}, {0.5f, vec4(0.0f)}, {0.5f, vec4(1.0f)}, {1.0f, vec4(1.0f)}}, 257);
        // 257 entries: entry 128 sits at exactly 0.5.
        check_rgba(step.entries()[127], vec4(0.0f));
        check_rgba(step.entries()[128], vec4(1.0f));
        CHECK(step.at(127.5f / 256.0f).a == Approx(0.5));
    }
}

TEST_CASE("packed_rgba8: R in bits 0-7 ... A in bits 24-31, round(c * 255)", "[tf]") {
    CHECK(TransferFunction::pack_rgba8({1.0f, 0.5f, 0.0f, 0.2f}) == 0x330080FFu);
    CHECK(TransferFunction::pack_rgba8({0.0f, 0.0f, 0.0f, 1.0f}) == 0xFF000000u);
    check_rgba(TransferFunction::unpack_rgba8(0x330080FFu), {1.0f, 128.0f / 255.0f, 0.0f, 0.2f});
    TransferFunction tf = red_to_blue();
    auto words = tf.packed_rgba8();
    REQUIRE(words.size() == 256);
    CHECK(words[0] == 0x000000FFu);    // red, alpha 0
    CHECK(words[255] == 0xFFFF0000u);  // blue, alpha 1
    CHECK(words[153] == 0xFFFF0000u);  // 153 / 255 = 0.6: the blue point itself
    CHECK(words[77] == TransferFunction::pack_rgba8(vec4(1.0f - 26.0f / 102.0f, 0.0f, 26.0f / 102.0f, 26.0f / 102.0f)));
    for (std::size_t i = 0; i < words.size(); ++i) {
        vec4 back = TransferFunction::unpack_rgba8(words[i]);
        for (int c = 0; c < 4; ++c) CHECK(std::abs(back[c] - tf.entries()[i][c]) <= 0.5f / 255.0f + 1e-6f);
    }
}

TEST_CASE("opacity queries and presets", "[tf]") {
    TransferFunction ramp = TransferFunction::ramp(0.25f, 0.75f, {0.2f, 0.4f, 0.6f, 0.8f});
    CHECK(ramp.at(0.1f).a == 0.0f);
    CHECK(ramp.at(0.5f).a == Approx(0.4f).margin(1e-5));
    check_rgba(ramp.at(0.5f), {0.2f, 0.4f, 0.6f, 0.4f}, 1e-5);
    CHECK(ramp.max_alpha() == Approx(0.8f));
    CHECK(ramp.any_opaque());
    TransferFunction clear({{0.0f, {1.0f, 1.0f, 1.0f, 0.0f}}});
    CHECK_FALSE(clear.any_opaque());
    CHECK(clear.max_alpha() == 0.0f);
    TransferFunction grey;
    CHECK(grey.at(0.5f).a == Approx(0.5f).margin(1e-6));
    TransferFunction ct = TransferFunction::ct_bone_tissue();
    CHECK(ct.at(0.05f).a == 0.0f);
    CHECK(ct.at(0.098f).a == 0.0f);  // below the noise threshold of 0.1
    CHECK(ct.at(0.15f).a > 0.0f);
    CHECK(ct.at(0.9f).a > 0.8f);
    CHECK(ct.max_alpha() == Approx(0.95f));
    CHECK_THROWS_WITH(TransferFunction::ramp(0.5f, 0.5f, vec4(1.0f)), Contains("lo < hi"));
    CHECK_THROWS_WITH(TransferFunction::ramp(std::nanf(""), 0.5f, vec4(1.0f)), Contains("lo < hi"));
}

TEST_CASE("bad control points and sizes are errors", "[tf][errors]") {
    CHECK_THROWS_WITH(TransferFunction(std::vector<ControlPoint>{}), Contains("no control points"));
    CHECK_THROWS_WITH(TransferFunction({{0.0f, vec4(1.0f)}}, 255), Contains("255 entries"));
    CHECK_THROWS_WITH(TransferFunction({{0.0f, vec4(1.0f)}}, 70000), Contains("70000 entries"));
    CHECK_THROWS_WITH(TransferFunction({{0.0f, vec4(1.0f)}, {0.5f, {0.0f, 1.5f, 0.0f, 1.0f}}}),
                      Contains("control point 1") && Contains("g = 1.5"));
    CHECK_THROWS_WITH(TransferFunction({{std::nanf(""), vec4(1.0f)}}),
                      Contains("control point 0") && Contains("density"));
    CHECK_THROWS_WITH(TransferFunction({{0.0f, {0.0f, 0.0f, 0.0f, std::nanf("")}}}), Contains("a = nan"));
}

TEST_CASE("text transfer functions: 'density r g b a' lines with # comments", "[tf][io]") {
    TempDir dir;
    write_file(dir / "tf.txt", "# density r g b a\n\n0.6 0 0 1 1   # blue\r\n\t0.2 1 0 0 0\n   \n");
    TransferFunction tf = TransferFunction::from_text(dir / "tf.txt");
    check_rgba(tf.at(0.4f), {0.5f, 0.0f, 0.5f, 0.5f});
    CHECK(TransferFunction::from_text(dir / "tf.txt", 512).size() == 512);
    auto fails_with = [&](const std::string& text, const std::string& what) {
        write_file(dir / "bad.txt", text);
        CHECK_THROWS_WITH(TransferFunction::from_text(dir / "bad.txt"), Contains(what) && Contains("bad.txt"));
    };
    fails_with("0 0 0 0 0\n0.5 1 1 1\n", "line 2: expected 'density r g b a' (5 numbers), found 4");
    fails_with("0 0 0 0 0 0\n", "line 1: expected");
    fails_with("# c\n0 0 zero 0 0\n", "line 2: 'zero' is not a finite number");
    fails_with("0 0 0 0 inf\n", "'inf' is not a finite number");
    fails_with("0 0 0 0 0\n\n\n1 1 1 1 1.01\n", "line 4");
    fails_with("# only comments\n\n", "no control points");
    fails_with("", "no control points");
    CHECK_THROWS_WITH(TransferFunction::from_text(dir / "missing.txt"),
                      Contains("missing.txt") && Contains("cannot open"));
}

TEST_CASE("JSON transfer functions: {\"points\": [[d, r, g, b, a], ...], \"entries\": N}", "[tf][io]") {
    TempDir dir;
    write_file(dir / "tf.json",
               "{\n  \"name\": \"red to blue\", \"meta\": {\"tags\": [1, true, null, \"x\\\"y\"]},\n"
               "  \"points\": [[0.6, 0, 0, 1, 1],\n             [2e-1, 1, 0, 0, 0]],\n  \"entries\": 512\n}\n");
    TransferFunction tf = TransferFunction::from_json(dir / "tf.json");
    CHECK(tf.size() == 512);
    check_rgba(tf.at(0.4f), {0.5f, 0.0f, 0.5f, 0.5f}, 1e-5);
    write_file(dir / "default.json", "{\"points\":[[0,0,0,0,0],[1,1,1,1,1]]}");
    CHECK(TransferFunction::from_json(dir / "default.json").size() == 256);
    auto fails_with = [&](const std::string& text, const std::string& what) {
        write_file(dir / "bad.json", text);
        CHECK_THROWS_WITH(TransferFunction::from_json(dir / "bad.json"), Contains(what) && Contains("bad.json"));
    };
    fails_with("{\"entries\": 256}", "missing \"points\"");
    fails_with("{\"points\": []}", "\"points\" is empty");
    fails_with("{\"points\": [[0,0,0,0,0]], \"entries\": 100}", "256 to 65536");
    fails_with("{\"points\": [[0,0,0,0,0]], \"entries\": 300.5}", "whole number");
    fails_with("{\n\"points\": [\n[0, 0, 0, 0, 0],\n[1, 1, 1, 1]\n]}", "point 1 has 4 numbers; a point is exactly 5");
    fails_with("{\"points\": [[0, 0, 0, 0, 0, 0]]}", "point 0 has 6 numbers");
    fails_with("{\n\"points\": [[0, 0, 0, 0, 0],\n  [1, 1, 1, 1, 2]]}", "point 1: a = 2");
    fails_with("{\"points\": [[0, 0, 0, 0, 0],]}", "line 1, column 29: syntax error");
    fails_with("{\"points\": [[0, 0, 0, 0, 0]]", "unexpected end of input; expected '}'");
    fails_with("{\"points\": [[0, 0, 0, 0, 0]]} trailing", "expected end of input");
    fails_with("{\"points\": [[0, 0, 0, 0, 0]], \"points\": [[1,1,1,1,1]]}", "given twice");
    fails_with("{\"points\": [[0, 0, nan, 0, 0]]}", "invalid literal");
    fails_with("{\"points\": [[1e308, 0, 0, 0, 0]]}", "point 0: '1e+308' is outside the float32 range");
    fails_with("{\"points\": [[1e400, 0, 0, 0, 0]]}", "number overflow");
    fails_with("{\"points\": [[0, \"red\", 0, 0, 0]]}", "point 0: value 1 is string, not a number");
    fails_with("{\"points\": {\"d\": 0}}", "\"points\" must be an array");
    fails_with("{\"points\": [[0, 0, 0, 0, 0]], \"entries\": 1e300}", "outside the float32 range");
    fails_with("{\"name\": \"unterminated}", "missing closing quote");
    fails_with("{\"x\": " + std::string(100, '[') + std::string(100, ']') + ", \"points\": [[0,0,0,0,0]]}",
               "deeper than 64");
    fails_with("[[0, 0, 0, 0, 0]]", "expected an object");
    fails_with("", "unexpected end of input");
    CHECK_THROWS_WITH(TransferFunction::from_json(dir / "missing.json"),
                      Contains("missing.json") && Contains("cannot open"));
}

TEST_CASE("transfer-function numbers beyond float32 are refused for that, not as non-finite", "[tf][io][errors]") {
    TempDir dir;
    write_file(dir / "big.txt", "0 0 0 0 0\n1e308 1 1 1 1\n");
    CHECK_THROWS_WITH(TransferFunction::from_text(dir / "big.txt"),
                      Contains("line 2") && Contains("'1e308' is outside the float32 range") && !Contains("not a finite"));
    write_file(dir / "small.txt", "0 0 0 0 0\n1e-300 1 1 1 1\n");  // underflows to 0: a valid density
    CHECK_NOTHROW(TransferFunction::from_text(dir / "small.txt"));
}

TEST_CASE("from_file: a .json extension in any letter case is JSON, anything else text", "[tf][io]") {
    TempDir dir;
    const std::string json = "{\"points\": [[0, 0, 0, 0, 0], [1, 1, 0, 0, 1]], \"entries\": 300}";
    for (const char* name : {"tf.json", "tf.JSON", "tf.Json"}) {
        write_file(dir / name, json);
        CHECK(TransferFunction::from_file(dir / name).size() == 300);
    }
    write_file(dir / "tf.txt", "0 0 0 0 0\n1 1 0 0 1\n");
    CHECK(TransferFunction::from_file(dir / "tf.txt").size() == TransferFunction::default_entries);
}
