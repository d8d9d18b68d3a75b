// Real volumes from ../shared/data: the full-resolution cut renders the reference marcher's
// image bit for bit (shaded, the default border 2, both brick sizes), and the build's ranges
// hold every voxel.
#include <catch2/catch.hpp>

#include <bit>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/validate.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/read.hpp>

#include "../missing_data.hpp"

using namespace sylva;

namespace {

/// The data file's path; missing data fail the test, or skip it (tests/missing_data.hpp).
std::string data_file(const std::string& name) { return testdata::require(name).string(); }

}  // namespace

TEST_CASE("data: the octree's full-resolution DVR equals the marcher's on aneurism, bonsai, lobster", "[data][dvr]") {
    ThreadPool pool(2);
    for (const char* name : {"aneurism_256x256x256_uint8.raw", "bonsai_256x256x256_uint8.raw", "lobster_301x324x56_uint8.raw"}) {
        std::string path = data_file(name);
        // The lobster's slices are 1.4 apart (../shared/data/README.md): a spacing whose inverse
        // is not exact, so voxel-space leaf bounds and world-space samples round differently.
        std::optional<vec3> spacing;
        if (std::string(name).starts_with("lobster")) spacing = vec3(1.0f, 1.0f, 1.4f);
        volume::DensityGrid g = volume::normalize(volume::read_volume(path, spacing));
        GridWords gw = GridWords::from(g);  // the octree's default border too: a constant 0
        VolumeRenderParams p;
        p.width = p.height = 80;
        p.camera = Camera::framing(g.world_box(), {0.4f, 0.3f, 1.0f}, 30.0f).frame(p.width, p.height);
        p.tf.resize(256);
        for (std::uint32_t i = 0; i < 256; ++i)
            p.tf[i] = (40 + i * 3 / 4) | ((200 - i / 2) << 8) | ((250 - i * 2 / 3) << 16) | ((i < 26 ? 0u : (i - 26) / 5) << 24);
        p.shading = true;
        Frame ref = render_dvr_cpu(gw, p, pool);
        for (std::uint32_t b : {32u, 16u}) {
            octree::Tree t = octree::build(g, pool, {b, 2});
            std::vector<std::uint32_t> words = octree::encode(t);
            REQUIRE_NOTHROW(octree::validate(words, t.bricks));
            const octree::Node& root = t.nodes[0];
            auto [lo, hi] = std::minmax_element(g.values.begin(), g.values.end());
            CHECK(root.min == *lo);
            CHECK(root.max == *hi);
            Frame oct = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);
            std::size_t differing = 0, lit = 0;
            for (std::size_t i = 0; i < ref.rgba.size(); ++i) {
                for (int c = 0; c < 4; ++c)
                    if (std::bit_cast<std::uint32_t>(ref.rgba[i][c]) != std::bit_cast<std::uint32_t>(oct.rgba[i][c])) {
                        ++differing;
                        break;
                    }
                lit += ref.rgba[i].w > 0.05f ? 1 : 0;
            }
            INFO(name << " B " << b);
            CHECK(differing == 0);
            CHECK(lit > ref.rgba.size() / 32);  // the image is not empty (aneurism: ~6% of it)
        }
    }
}
