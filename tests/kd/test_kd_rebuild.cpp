// kdtree::Rebuilder: a sequence of transfer functions and thresholds over uint8, uint16 and
// float32 volumes and a density grid gives, every time, the tree a fresh build gives
// (build_binned / build_parallel over volume::classified), and trees that pass the brute-force
// invariants (reference.hpp) on an occupancy classified here by hand. Reuse of storage, the
// empty and all-opaque transfer functions, bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/build_parallel.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/rebuild.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read_raw.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;
using kdtree::Config;
using kdtree::Tree;
using volume::ControlPoint;
using volume::TransferFunction;

namespace {

/// A volume of `type` holding `g`'s densities: uint8 round(d 255), uint16 round(d 65535),
/// float32 d * 7 - 2 over the range [-2, 5].
volume::Volume volume_of(const volume::DensityGrid& g, volume::ScalarType type) {
    volume::Volume v;
    v.type = type;
    v.dims = g.dims;
    v.spacing = g.spacing;
    v.bytes.resize(g.values.size() * volume::scalar_bytes(type));
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        float d = g.values[i];
        if (type == volume::ScalarType::U8) {
            v.bytes[i] = std::byte(static_cast<std::uint8_t>(std::lround(d * 255.0f)));
        } else if (type == volume::ScalarType::U16) {
            auto u = static_cast<std::uint16_t>(std::lround(d * 65535.0f));
            std::memcpy(&v.bytes[2 * i], &u, 2);
        } else {
            float f = d * 7.0f - 2.0f;
            std::memcpy(&v.bytes[4 * i], &f, 4);
        }
    }
    v.range_lo = type == volume::ScalarType::F32 ? -2.0f : 0.0f;
    v.range_hi = type == volume::ScalarType::U8 ? 255.0f : (type == volume::ScalarType::U16 ? 65535.0f : 5.0f);
    return v;
}

TransferFunction constant_alpha(float a) { return TransferFunction({{0.0f, vec4(1.0f, 1.0f, 1.0f, a)}}); }

/// The transfer functions of the replay: ramps, the CT preset, a narrow band, a finer table,
/// none opaque, all opaque.
std::vector<std::pair<std::string, TransferFunction>> tf_sequence() {
    return {{"ramp 0.1-0.5", TransferFunction::ramp(0.1f, 0.5f, vec4(1.0f))},
            {"ct bone/tissue", TransferFunction::ct_bone_tissue()},
            {"steep 0.40-0.41", TransferFunction::ramp(0.40f, 0.41f, vec4(1.0f, 0.5f, 0.2f, 0.8f))},
            {"none opaque", constant_alpha(0.0f)},
            {"band 0.2-0.3", TransferFunction({{0.2f, vec4(0.0f)}, {0.25f, vec4(0.5f)}, {0.3f, vec4(0.0f)}})},
            {"all opaque", constant_alpha(1.0f)},
            {"ramp 1024 entries", TransferFunction::ramp(0.05f, 0.2f, vec4(0.3f), 1024)},
            {"ramp 0.1-0.5 again", TransferFunction::ramp(0.1f, 0.5f, vec4(1.0f))}};
}

std::vector<std::pair<const char*, Config>> rebuild_configs() {
    return {{"shallow", Config::shallow()},
            {"deep", Config::deep()},
            {"shallow binned", Config::shallow().binned()},
            {"deep binned", Config::deep().binned()},
            {"deep binned 8", Config::deep().binned(8)}};
}

/// The fresh build the Rebuilder must reproduce.
template <class Source, class C, class X>
Tree fresh_build(const Source& s, const C& classify, const Config& cfg, X& exec) {
    auto src = volume::classified(s, classify);
    return cfg.planes == kdtree::Planes::Binned ? kdtree::build_binned(src, cfg, exec)
                                                : kdtree::build_parallel(src, cfg, exec);
}

void require_same_tree(const Tree& a, const Tree& b) {
    REQUIRE(a.nodes.size() == b.nodes.size());
    for (std::size_t i = 0; i < a.nodes.size(); ++i) REQUIRE(a.nodes[i] == b.nodes[i]);
    REQUIRE(a.leaves == b.leaves);
    CHECK(a.dims == b.dims);
    CHECK(a.spacing == b.spacing);
    CHECK(a.stats.voxels == b.stats.voxels);
    CHECK(a.stats.occupied == b.stats.occupied);
    CHECK(a.stats.leaf_volume == b.stats.leaf_volume);
    CHECK(a.stats.max_depth == b.stats.max_depth);
}

/// The occupancy of `g` under `tf` classified here: alpha of the float entries, interpolated
/// in double precision, compared with a margin so that only clear cases are asserted.
Occupancy occupancy_by_hand(const volume::DensityGrid& g, const TransferFunction& tf) {
    Occupancy o{g.dims, g.spacing, std::vector<std::uint8_t>(g.values.size())};
    const auto& e = tf.entries();
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        double x = std::clamp(double(g.values[i]), 0.0, 1.0) * double(e.size() - 1);
        std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(x), e.size() - 2);
        double a = e[k].a + (double(e[k + 1].a) - e[k].a) * (x - double(k));
        o.voxels[i] = a > 0.0 ? 1u : 0u;
    }
    return o;
}

volume::DensityGrid test_grid() {
    volume::SparseNbodyConfig c;
    c.blobs = 300;
    c.halos = 6;
    c.blob_sigma = 0.03f;
    return volume::sparse_nbody({45, 37, 29}, 3, c);
}

}  // namespace

TEST_CASE("rebuild: every transfer function of a replay gives the fresh build's tree", "[kd][rebuild]") {
    volume::DensityGrid g = test_grid();
    ThreadPool pool(2);
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        volume::Volume v = volume_of(g, type);
        for (const auto& [cname, cfg] : rebuild_configs()) {
            kdtree::Rebuilder r(v, cfg, pool);
            for (const auto& [tname, tf] : tf_sequence()) {
                INFO(volume::scalar_name(type) << ", " << cname << ", " << tname);
                Tree t = r.rebuild(tf);
                require_same_tree(t, fresh_build(v, volume::TransferFunctionAlpha(tf), cfg, pool));
                CHECK(r.timings().split_ms >= 0.0);
                CHECK(t.stats.occupancy_ms == Approx(r.timings().classify_ms + r.timings().occupancy_ms));
            }
        }
    }
}

TEST_CASE("rebuild: density grids and thresholds, trees checked against brute force", "[kd][rebuild]") {
    volume::DensityGrid g = test_grid();
    SerialExecutor serial;
    for (const auto& [cname, cfg] : rebuild_configs()) {
        kdtree::Rebuilder r(g, cfg, serial);
        for (const auto& [tname, tf] : tf_sequence()) {
            INFO(cname << ", " << tname);
            Tree t = r.rebuild(tf);
            require_same_tree(t, fresh_build(g, volume::TransferFunctionAlpha(tf), cfg, serial));
            check_tree(t, occupancy_by_hand(g, tf));
        }
        for (float th : {0.05f, 0.3f, 0.9f, 2.0f}) {
            INFO(cname << ", threshold " << th);
            require_same_tree(r.rebuild(volume::DensityThreshold{th}),
                              fresh_build(g, volume::DensityThreshold{th}, cfg, serial));
        }
    }
}

TEST_CASE("rebuild: no opaque entry gives an empty tree, all opaque the whole grid", "[kd][rebuild]") {
    volume::DensityGrid g = test_grid();
    volume::Volume v = volume_of(g, volume::ScalarType::U8);
    ThreadPool pool(2);
    for (const auto& [cname, cfg] : rebuild_configs()) {
        INFO(cname);
        kdtree::Rebuilder r(v, cfg, pool);
        Tree none = r.rebuild(constant_alpha(0.0f));
        CHECK(none.nodes.empty());
        CHECK(none.leaves.empty());
        CHECK(none.stats.occupied == 0);
        CHECK(none.stats.voxels == g.values.size());
        std::vector<std::uint32_t> words = kdtree::encode(none);  // header only, node count 0
        CHECK(words.size() == SYLVA_KD_HEADER_WORDS);
        CHECK(words[3] == 0u);
        Tree all = r.rebuild(constant_alpha(1.0f));
        REQUIRE_FALSE(all.nodes.empty());
        CHECK(all.nodes[0].box == volume::full_box(v.dims));
        CHECK(all.stats.occupied == g.values.size());
        CHECK(all.stats.leaf_volume == g.values.size());
        // the per-voxel verdict of min_alpha: 0.5 drops the voxels that constant alpha 0.5 has
        CHECK(r.rebuild(constant_alpha(0.5f), 0.5f).nodes.empty());
        CHECK(r.rebuild(constant_alpha(0.5f), 0.25f).stats.occupied == g.values.size());
    }
}

TEST_CASE("rebuild: block value ranges decide blocks without reading them", "[kd][rebuild]") {
    volume::DensityGrid g = test_grid();
    SerialExecutor serial;
    std::size_t blocks = std::size_t{6 * 5 * 4};
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        INFO(volume::scalar_name(type));
        volume::Volume v = volume_of(g, type);
        kdtree::Rebuilder r(v, Config::deep().binned(), serial);
        CHECK(r.prepare_ms() > 0.0);
        r.rebuild(constant_alpha(0.0f));
        CHECK(r.timings().blocks_read == 0u);  // every block empty by its range
        r.rebuild(volume::DensityThreshold{0.0f});
        CHECK(r.timings().blocks_read == 0u);  // every block full by its range
        Tree t = r.rebuild(TransferFunction::ramp(0.5f, 0.6f, vec4(1.0f)));
        CHECK(r.timings().blocks_read > 0u);
        CHECK(r.timings().blocks_read < blocks);
        CHECK(t.stats.occupied > 0u);
        // a classifier the ranges cannot decide for float voxels reads every block
        auto band = [](float d) { return d > 0.5f; };
        require_same_tree(r.rebuild(band), fresh_build(v, band, Config::deep().binned(), serial));
        if (type == volume::ScalarType::F32) CHECK(r.timings().blocks_read == blocks);
    }
}

namespace {

/// Voxels in runs of equal values (whole blocks constant, some blocks mixed), raw values across
/// the type's range (float32: [-3, 6] around the range [-2, 5], one infinity in grids).
volume::Volume blocky_volume(volume::Dims d, volume::ScalarType type, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::DensityGrid g{d, vec3(1.0f), std::vector<float>(std::size_t{d.x} * d.y * d.z)};
    for (std::uint32_t z = 0; z < d.z; ++z)
        for (std::uint32_t y = 0; y < d.y; ++y)
            for (std::uint32_t x = 0; x < d.x; ++x) {
                std::uint32_t block = (x / 8) * 7 + (y / 8) * 13 + (z / 8) * 29;
                float level = float(block % 5) / 4.0f;  // constant blocks of 0, 0.25, .. 1
                g.values[volume::voxel_index(d, x, y, z)] = (block % 3 == 0) ? u(rng) : level;
            }
    return volume_of(g, type);
}

/// The words of a full pass and of the verdict-driven pass must agree.
template <class Source, class C>
void check_verdicts(const Source& src, const volume::Volume* v, const C& classify) {
    SerialExecutor serial;
    kdtree::BoxSource s = kdtree::BoxSource::of(*v);
    kdtree::BlockValues values;
    kdtree::block_values(s, serial, values);
    std::vector<std::uint8_t> table, verdicts;
    std::vector<std::uint32_t> scratch, full, skipping;
    if (s.source != SYLVA_KD_BOX_SOURCE_F32) kdtree::value_table(s, classify, table);
    kdtree::block_verdicts(s, values, classify, table, scratch, verdicts);
    kdtree::block_words(src, serial, full);
    kdtree::block_words(src, verdicts, serial, skipping);
    REQUIRE(full == skipping);
    for (std::size_t b = 0; b < full.size(); ++b) {  // decided blocks: their words say so
        if (verdicts[b] == kdtree::kBlockEmpty) REQUIRE(full[b] == 0u);
        if (verdicts[b] != kdtree::kBlockFull) continue;
        uvec3 c(b % 5, (b / 5) % 4, b / 20);  // 37x29x21: 5x4x3 blocks
        VoxelBox block{c * 8u, glm::min(c * 8u + 8u, uvec3(37u, 29u, 21u))};
        REQUIRE(kdtree::block_word_box(c, full[b]) == block);
    }
}

}  // namespace

TEST_CASE("rebuild: verdict-driven block words equal a full pass", "[kd][rebuild]") {
    std::vector<volume::TransferFunctionAlpha> tfs{
        volume::TransferFunctionAlpha(TransferFunction::ramp(0.3f, 0.6f, vec4(1.0f))),
        volume::TransferFunctionAlpha(TransferFunction({{0.2f, vec4(0.0f)}, {0.25f, vec4(0.5f)}, {0.3f, vec4(0.0f)}})),
        volume::TransferFunctionAlpha(TransferFunction::ct_bone_tissue(), 1e-6f),
        volume::TransferFunctionAlpha(constant_alpha(0.0f)), volume::TransferFunctionAlpha(constant_alpha(1.0f))};
    std::uint32_t seed = 1;
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        volume::Volume v = blocky_volume({37, 29, 21}, type, seed++);
        INFO(volume::scalar_name(type));
        for (const auto& tf : tfs) check_verdicts(volume::classified(v, tf), &v, tf);
        for (float th : {0.0f, 0.25f, 0.5f, 0.99f, 1.0f, 1.5f})
            check_verdicts(volume::classified(v, volume::DensityThreshold{th}), &v, volume::DensityThreshold{th});
        auto band = [](float d) { return d > 0.2f && d < 0.6f; };
        check_verdicts(volume::classified(v, band), &v, band);
    }
}

TEST_CASE("rebuild: the blocks' Morton order is every block once, ascending code", "[kd][rebuild]") {
    for (volume::Dims d : {volume::Dims{1, 1, 1}, volume::Dims{256, 256, 256}, volume::Dims{100, 8, 300},
                           volume::Dims{9, 1000, 17}, volume::Dims{8000, 1, 1}}) {
        INFO(d.x << "x" << d.y << "x" << d.z);
        kdtree::BlockOrder o = kdtree::BlockOrder::of(d);
        uvec3 nb = kdtree::block_counts(d);
        std::vector<std::pair<std::uint64_t, std::uint32_t>> want;
        for (std::uint32_t i = 0; i < nb.x * nb.y * nb.z; ++i)
            want.push_back({kdtree::morton3(uvec3(i % nb.x, (i / nb.x) % nb.y, i / (nb.x * nb.y))), i});
        std::sort(want.begin(), want.end());
        REQUIRE(o.size() == want.size());
        std::size_t wrong = 0;
        for (std::size_t k = 0; k < want.size(); ++k) wrong += (o.code[k] != want[k].first || o.index[k] != want[k].second) ? 1u : 0u;
        CHECK(wrong == 0);
    }
}

TEST_CASE("rebuild: storage is reused across rebuilds", "[kd][rebuild]") {
    volume::Volume v = volume_of(test_grid(), volume::ScalarType::U16);
    SerialExecutor serial;
    kdtree::Rebuilder r(v, Config::deep().binned(), serial);
    r.rebuild(constant_alpha(1.0f));  // every block non-empty: the largest box arrays
    const VoxelBox* boxes = r.local_boxes().boxes.data();
    const std::uint64_t* codes = r.local_boxes().codes.data();
    std::size_t all = r.local_boxes().boxes.size();
    CHECK(all == std::size_t{6 * 5 * 4});
    for (const auto& [tname, tf] : tf_sequence()) {
        INFO(tname);
        r.rebuild(tf);
        CHECK(r.local_boxes().boxes.data() == boxes);
        CHECK(r.local_boxes().codes.data() == codes);
        CHECK(std::is_sorted(r.local_boxes().codes.begin(), r.local_boxes().codes.end()));
    }
}

TEST_CASE("rebuild: bad input", "[kd][rebuild]") {
    SerialExecutor serial;
    volume::DensityGrid g = test_grid();
    volume::Volume v = volume_of(g, volume::ScalarType::F32);
    Config bad_raster = Config::deep().binned();
    bad_raster.raster = 4;
    CHECK_THROWS_AS(kdtree::Rebuilder(v, bad_raster, serial), Error);
    Config bad_fraction = Config::shallow();
    bad_fraction.min_volume_fraction = 2.0;
    CHECK_THROWS_AS(kdtree::Rebuilder(v, bad_fraction, serial), Error);
    float nan = std::nanf("");
    std::memcpy(&v.bytes[4 * 1234], &nan, 4);
    for (const auto& [cname, cfg] : rebuild_configs()) {
        INFO(cname);
        kdtree::Rebuilder r(v, cfg, serial);
        CHECK_THROWS_AS(r.rebuild(TransferFunction::ct_bone_tissue()), Error);
    }
    volume::Volume short_volume = volume_of(g, volume::ScalarType::U8);
    short_volume.bytes.pop_back();
    CHECK_THROWS_AS(kdtree::Rebuilder(short_volume, Config::shallow(), serial), Error);
}

TEST_CASE("rebuild: aneurism under a replay of transfer functions", "[kd][rebuild][data]") {
    std::filesystem::path p = testdata::require("aneurism_256x256x256_uint8.raw");  // fails (or skips) when missing
    volume::Volume v = volume::read_raw(p, volume::parse_raw_name(p.filename().string()));
    ThreadPool pool(2);
    for (const Config& cfg : {Config::deep().binned(), Config::shallow()}) {
        kdtree::Rebuilder r(v, cfg, pool);
        for (const auto& [tname, tf] : tf_sequence()) {
            INFO(tname);
            require_same_tree(r.rebuild(tf), fresh_build(v, volume::TransferFunctionAlpha(tf), cfg, pool));
        }
        // Kinkelin's threshold: 113,453 voxels of value / 255 >= 0.1 (docs/DESIGN.md, Data)
        CHECK(r.rebuild(volume::DensityThreshold{0.1f}).stats.occupied == 113453u);
    }
}
