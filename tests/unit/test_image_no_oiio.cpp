// sylva/render/image.hpp built without OpenImageIO (SYLVA_HAVE_OIIO=0, as the sylva_image target
// defines when the package is missing): frames and heat maps are written as binary PPM and PFM,
// read back here byte for byte, and any other extension is refused naming the missing library.
#define SYLVA_HAVE_OIIO 0
#include <sylva/render/image.hpp>

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace sylva;

namespace {
std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Frame two_by_two() {
    Frame f;
    f.width = 2;
    f.height = 2;
    f.rgba = {vec4(1.0f, 0.0f, 0.0f, 1.0f), vec4(0.0f, 0.5f, 0.0f, 0.5f), vec4(0.0f), vec4(0.25f, 0.25f, 0.25f, 1.0f)};
    f.steps = {1, 2, 3, 0xFFFFFFFFu};
    return f;
}
}  // namespace

TEST_CASE("without OpenImageIO a frame is written as binary PPM (8-bit sRGB) and PFM (float RGB)", "[image]") {
    const auto dir = std::filesystem::temp_directory_path() / "sylva_image_no_oiio";
    std::filesystem::create_directories(dir);
    const Frame f = two_by_two();
    write_frame((dir / "f.ppm").string(), f);
    const std::string ppm = slurp(dir / "f.ppm");
    REQUIRE(ppm.size() == std::string("P6\n2 2\n255\n").size() + 12);
    CHECK(ppm.rfind("P6\n2 2\n255\n", 0) == 0);
    const auto* px = reinterpret_cast<const unsigned char*>(ppm.data() + ppm.size() - 12);
    CHECK(px[0] == 255);  // red, opaque
    CHECK(px[1] == 0);
    CHECK(px[4] == static_cast<unsigned char>(std::lround(detail::to_srgb(0.5f) * 255.0f)));  // premultiplied green
    CHECK(px[6] == 0);  // transparent over black
    CHECK(px[9] == static_cast<unsigned char>(std::lround(detail::to_srgb(0.25f) * 255.0f)));

    write_frame((dir / "f.pfm").string(), f);
    const std::string pfm = slurp(dir / "f.pfm");
    const std::string header = "PF\n2 2\n-1.0\n";
    REQUIRE(pfm.size() == header.size() + 4 * 3 * sizeof(float));
    CHECK(pfm.rfind(header, 0) == 0);
    std::vector<float> rgb(12);
    std::memcpy(rgb.data(), pfm.data() + header.size(), rgb.size() * sizeof(float));
    // Bottom row first: pixels 2 and 3, then 0 and 1; alpha dropped.
    CHECK(rgb[0] == 0.0f);
    CHECK(rgb[3] == 0.25f);
    CHECK(rgb[6] == 1.0f);
    CHECK(rgb[10] == 0.5f);

    CHECK(write_heatmap((dir / "h.ppm").string(), f) == 3u);
    CHECK(slurp(dir / "h.ppm").size() == std::string("P6\n2 2\n255\n").size() + 12);
    std::filesystem::remove_all(dir);
}

TEST_CASE("without OpenImageIO other formats are refused, naming the library and what to write instead", "[image]") {
    const auto dir = std::filesystem::temp_directory_path() / "sylva_image_no_oiio_refused";
    std::filesystem::create_directories(dir);
    const Frame f = two_by_two();
    CHECK_THROWS_WITH(write_frame((dir / "f.png").string(), f),
                      Catch::Contains("OpenImageIO") && Catch::Contains(".ppm"));
    CHECK_THROWS_WITH(write_frame((dir / "f.exr").string(), f), Catch::Contains(".pfm"));
    CHECK_THROWS_WITH(write_heatmap((dir / "h.png").string(), f), Catch::Contains("OpenImageIO"));
    CHECK_FALSE(std::filesystem::exists(dir / "f.png"));  // nothing half-written
    CHECK_THROWS_WITH(write_frame((dir / "missing" / "f.ppm").string(), f), Catch::Contains("cannot open"));
    std::filesystem::remove_all(dir);
}
