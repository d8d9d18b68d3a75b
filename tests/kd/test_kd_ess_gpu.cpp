// The ESS occupancy's undecided blocks on a Vulkan device (lavapipe in CI; shaders/kd_ess_boxes.comp,
// sylva/vulkan/kd_ess.hpp) against two references: the block words of the segment codes'
// occupancy (ess_codes, ess_occupancy, kdtree::block_words: an independent classification, voxel
// by voxel) and the same shared code run on the host. Float, native uint8 / uint16 and sparse
// grids, split grid bindings, sides that are and are not multiples of 8 down to 1x1x1, three
// borders, TFs of 100 to 1024 entries with up to 32 runs, several dispatch batches; the
// binned trees of vk::EssKdRebuilder equal sylva::EssRebuilder's over a replay; the aneurism.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/transfer_function.hpp>
#include <sylva/vulkan/kd_ess.hpp>

#include "../device_tolerance.hpp"
#include "reference.hpp"

using namespace sylva;
using kdtest::quantised;

namespace {

std::uint32_t rgba8(float r, float g, float b, float a) {
    auto c = [](float x) { return static_cast<std::uint32_t>(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); };
    return c(r) | (c(g) << 8) | (c(b) << 16) | (c(a) << 24);
}

/// A preset, a narrow band, 1024 entries, all and nothing visible, 32 runs of buckets, and a
/// 100-entry TF with 3 runs (buckets of several segments).
std::vector<std::pair<std::string, std::vector<std::uint32_t>>> tfs() {
    std::vector<std::uint32_t> band(256), comb(256), comb100(100);
    for (std::size_t i = 0; i < band.size(); ++i) {
        float d = float(i) / 255.0f;
        band[i] = rgba8(0.3f, 0.8f, 0.4f, d >= 0.3f && d <= 0.36f ? 0.4f : 0.0f);
        comb[i] = rgba8(1.0f, 1.0f, 1.0f, (i / 4) % 2 == 1 ? 0.5f : 0.0f);
    }
    for (std::size_t i = 0; i < comb100.size(); ++i) comb100[i] = rgba8(1.0f, 1.0f, 1.0f, i % 30 == 7 ? 0.5f : 0.0f);
    return {{"ct", volume::TransferFunction::ct_bone_tissue().packed_rgba8()},
            {"band", band},
            {"ramp, 1024 entries", volume::TransferFunction::ramp(0.2f, 0.6f, vec4(1.0f, 0.8f, 0.5f, 0.6f), 1024).packed_rgba8()},
            {"all visible", std::vector<std::uint32_t>(256, rgba8(1.0f, 1.0f, 1.0f, 0.5f))},
            {"nothing visible", std::vector<std::uint32_t>(256, rgba8(1.0f, 1.0f, 1.0f, 0.0f))},
            {"comb of 32 runs", comb},
            {"100 entries, 3 runs", comb100}};
}

std::vector<std::pair<std::string, GridBorder>> borders() {
    return {{"zero", GridBorder{}}, {"clamp", GridBorder{BorderMode::Clamp, 0.0f}}, {"0.33", GridBorder{BorderMode::Constant, 0.33f}}};
}

/// The smallest split shift that spreads `words` over more than one part (at most 4).
std::uint32_t spanning_shift(std::size_t words) {
    std::uint32_t shift = 1;
    while ((std::size_t{4} << shift) < words) ++shift;
    return shift;
}

struct Case {
    std::string name;
    GridWords words;
    std::uint32_t shift = 0;  ///< 0: one binding
};

/// Device words against the reference: equal on lavapipe; on a GPU, whose integer-grid
/// densities may be a few ulp off the host's (division to 2.5 ulp), at most
/// devtol::allowed_diverging blocks may differ.
bool words_agree(const vk::Context& ctx, const std::vector<std::uint32_t>& want, const std::vector<std::uint32_t>& got) {
    if (want.size() != got.size()) return false;
    std::size_t differing = 0;
    for (std::size_t i = 0; i < want.size(); ++i) differing += want[i] != got[i];
    if (differing != 0) devtol::note(ctx, std::to_string(differing) + " of " + std::to_string(want.size()) + " block words differ");
    return devtol::exact(ctx) ? differing == 0 : differing <= devtol::allowed_diverging(ctx, want.size());
}

/// The block words of the segment codes' occupancy of `g` under `tf`: the reference.
std::vector<std::uint32_t> codes_words(const GridWords& g, const std::vector<std::uint32_t>& tf, ThreadPool& pool) {
    EssClassifier cls = ess_classifier(tf);
    volume::Occupancy occ = ess_occupancy(ess_codes(g, cls.entries(), pool), cls, pool);
    std::vector<std::uint32_t> w;
    kdtree::block_words(occ, pool, w);
    return w;
}

}  // namespace

TEST_CASE("ESS occupancy on Vulkan: block words equal the segment codes' occupancy", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    volume::DensityGrid blobs = volume::sparse_nbody({40, 44, 36}, 6u), odd = volume::sparse_nbody({17, 9, 23}, 6u);
    volume::DensityGrid ml = volume::marschner_lobb({33, 30, 27});
    std::vector<Case> cases;
    cases.push_back({"float blobs 40x44x36, split bindings", GridWords::from(blobs), 0});
    cases.back().shift = spanning_shift(cases.back().words.words.size());
    cases.push_back({"float Marschner-Lobb 33x30x27", GridWords::from(ml), 0});
    cases.push_back({"float 1x1x1", GridWords::from(volume::sparse_nbody({1, 1, 1}, 6u)), 0});
    cases.push_back({"float 1x12x3", GridWords::from(volume::sparse_nbody({1, 12, 3}, 6u)), 0});
    cases.push_back({"uint8 Marschner-Lobb", GridWords::native(quantised(ml, volume::ScalarType::U8)), 0});
    cases.push_back({"uint16 blobs 17x9x23", GridWords::native(quantised(odd, volume::ScalarType::U16)), 0});
    cases.push_back({"sparse uint8 blobs", GridWords::sparse(quantised(blobs, volume::ScalarType::U8)), 0});
    std::size_t compared = 0, listed_total = 0;
    for (Case& c : cases) {
        vk::DeviceGrid dgrid(ctx, c.words, c.shift);
        if (c.shift != 0) REQUIRE(dgrid.constants()[1] > 1u);
        vk::EssBoxPass pass(ctx, dgrid, c.words);
        for (const auto& [bname, border] : borders()) {
            c.words.sampling.border = border;  // the same words under another border (a parameter of the pass)
            EssBlockRanges ranges = ess_block_ranges(c.words, pool);
            for (const auto& [tf_name, tf] : tfs()) {
                INFO(c.name << ", border " << bname << ", " << tf_name);
                EssClassifier cls = ess_classifier(tf);
                std::vector<std::uint32_t> want = codes_words(c.words, tf, pool), got, all_read, host_words;
                std::vector<std::uint8_t> verdicts;
                ess_block_verdicts(ranges, cls, border, verdicts);
                pass.block_words(cls, verdicts, got);
                REQUIRE(words_agree(ctx, want, got));
                CHECK(pass.timings().cut_columns == 0);
                listed_total += static_cast<std::size_t>(std::count(verdicts.begin(), verdicts.end(), kdtree::kBlockRead));
                // Every block read on the device, and on the host through the same shared code.
                std::vector<std::uint8_t> all(verdicts.size(), kdtree::kBlockRead);
                pass.block_words(cls, all, all_read);
                REQUIRE(words_agree(ctx, want, all_read));
                std::vector<std::uint32_t> listed, masks;
                vk::kd_ess_listed(all, listed);
                auto params = vk::kd_ess_params(c.words.dims, c.words.sampling, cls.entries());
                std::vector<std::uint32_t> visible = vk::kd_ess_visible_words(cls);
                for (std::uint32_t b : listed)
                    for (std::uint32_t ly = 0; ly < 8; ++ly) {
                        uvec2 m = vk::reference_ess_column(c.words, params, visible, b, ly);
                        masks.insert(masks.end(), {m.x, m.y, 0u});
                    }
                vk::kd_ess_fold(c.words.dims, all, listed, masks, host_words);
                REQUIRE(host_words == want);
                ++compared;
            }
        }
    }
    CHECK(compared == cases.size() * 3 * 7);
    CHECK(listed_total > 100);  // the device read blocks, not only verdicts
}

TEST_CASE("ESS occupancy on Vulkan: several dispatch batches give the same words", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    GridWords g = GridWords::native(quantised(volume::sparse_nbody({40, 44, 36}, 6u), volume::ScalarType::U8));
    vk::DeviceGrid dgrid(ctx, g);
    vk::EssBoxPass one(ctx, dgrid, g), batched(ctx, dgrid, g, vk::EssBoxPassConfig{7});
    EssBlockRanges ranges = ess_block_ranges(g, pool);
    EssClassifier cls = ess_classifier(volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    std::vector<std::uint8_t> verdicts(std::size_t{ranges.blocks.x} * ranges.blocks.y * ranges.blocks.z, kdtree::kBlockRead);
    std::vector<std::uint32_t> a, b;
    one.block_words(cls, verdicts, a);
    batched.block_words(cls, verdicts, b);
    REQUIRE(verdicts.size() > 7 * 3);  // several batches, the last one partial
    CHECK(a == codes_words(g, volume::TransferFunction::ct_bone_tissue().packed_rgba8(), pool));
    CHECK(b == a);
}

TEST_CASE("vk::EssKdRebuilder gives EssRebuilder's binned trees over a replay", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    GridWords g = GridWords::native(quantised(volume::marschner_lobb({41, 38, 35}), volume::ScalarType::U16),
                                    GridBorder{BorderMode::Constant, 0.2f});
    vk::DeviceGrid dgrid(ctx, g);
    for (const kdtree::Config& cfg : {kdtree::Config::shallow().binned(), kdtree::Config::deep().binned()}) {
        vk::EssKdRebuilder<ThreadPool> gpu(ctx, dgrid, g, cfg, pool);
        EssRebuilder<ThreadPool> host(g, cfg, pool);
        std::size_t round = 0;
        for (const auto& [tf_name, tf] : tfs()) {
            INFO(tf_name);
            kdtree::Tree a = gpu.rebuild(tf), b = host.rebuild(tf);
            REQUIRE(a.nodes == b.nodes);
            CHECK(a.leaves == b.leaves);
            CHECK(a.stats.occupied == b.stats.occupied);
            CHECK(gpu.timings().blocks_read == host.timings().blocks_read);
            CHECK((round++ == 0) == (gpu.ranges_ms() > 0.0));  // the ranges' pass runs once
            CHECK(gpu.block_ranges() != nullptr);
        }
    }
    CHECK_THROWS_WITH(vk::EssKdRebuilder<ThreadPool>(ctx, dgrid, g, kdtree::Config::deep(), pool),
                      Catch::Contains("binned trees only"));
}

TEST_CASE("ESS occupancy on Vulkan: bad input", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    GridWords g = GridWords::from(volume::sparse_nbody({20, 18, 22}, 3u)), other = GridWords::from(volume::sparse_nbody({20, 18, 21}, 3u));
    vk::DeviceGrid dgrid(ctx, g);
    CHECK_THROWS_WITH(vk::EssBoxPass(ctx, dgrid, other), Catch::Contains("does not hold these grid words"));
    CHECK_THROWS_WITH(vk::EssBoxPass(ctx, dgrid, g, vk::EssBoxPassConfig{0}), Catch::Contains("batch_blocks"));
    CHECK_THROWS_WITH(vk::kd_ess_params(g.dims, g.sampling, 1u), Catch::Contains("1 entries"));
    vk::EssBoxPass pass(ctx, dgrid, g);
    EssClassifier cls = ess_classifier(volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    std::vector<std::uint32_t> words;
    CHECK_THROWS_WITH(pass.block_words(cls, std::vector<std::uint8_t>(5, kdtree::kBlockRead), words),
                      Catch::Contains("verdicts"));
}

TEST_CASE("ESS occupancy on Vulkan: the aneurism", "[parity][kd][data]") {
    std::filesystem::path p = testdata::require("aneurism_256x256x256_uint8.raw");  // fails (or skips) when missing
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    GridWords g = GridWords::native(volume::read_raw(p, volume::parse_raw_name(p.filename().string())));
    vk::DeviceGrid dgrid(ctx, g);
    vk::EssKdRebuilder<ThreadPool> gpu(ctx, dgrid, g, kdtree::Config::deep().binned(), pool);
    EssRebuilder<ThreadPool> host(g, kdtree::Config::deep().binned(), pool);
    for (const auto& tf : {volume::TransferFunction::ct_bone_tissue().packed_rgba8(),
                           volume::TransferFunction::ramp(0.1f, 0.5f, vec4(1.0f)).packed_rgba8()}) {
        kdtree::Tree a = gpu.rebuild(tf), b = host.rebuild(tf);
        REQUIRE(a.nodes == b.nodes);
        CHECK(a.stats.occupied == b.stats.occupied);
        CHECK(gpu.timings().blocks_read > 1000);
        CHECK(gpu.timings().blocks_read < 32768);
    }
}
