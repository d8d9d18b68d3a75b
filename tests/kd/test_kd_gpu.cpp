// The local-box pass on a Vulkan device (lavapipe in CI), shaders/kd_local_boxes.comp, against
// three references: the same shared code run on the host (identical words), the host pass
// kdtree::local_boxes over volume::classified (identical LocalBoxes: an independent
// implementation) and a brute-force scan of every block (tight_direct). Random uint8, uint16,
// float32 volumes, density grids and occupancies with dimensions that are not multiples of 8,
// all-empty, all-full, 1x1x1 and 1xNx1 grids, several slabs, the aneurism; the binned tree
// from device boxes equals the one from host boxes; vk::KdRebuilder equals kdtree::Rebuilder.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/gpu_local_boxes.hpp>
#include <sylva/kdtree/local_boxes.hpp>
#include <sylva/kdtree/rebuild.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/vulkan/kd_build.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;
using kdtree::Config;
using kdtree::LocalBoxes;
using volume::TransferFunction;

namespace {

/// Random raw voxels: clustered high values in a low background, so thresholds and transfer
/// functions cut through blocks. Float volumes span [-3, 6] around their range [-2, 5].
volume::Volume random_volume(volume::Dims d, volume::ScalarType type, std::uint32_t seed, double high = 0.15) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::Volume v;
    v.type = type;
    v.dims = d;
    std::size_t n = std::size_t{d.x} * d.y * d.z, bytes = volume::scalar_bytes(type);
    v.bytes.resize(n * bytes);
    for (std::size_t i = 0; i < n; ++i) {
        float x = u(rng) < high ? 0.3f + 0.7f * u(rng) : 0.35f * u(rng);
        if (type == volume::ScalarType::U8) {
            v.bytes[i] = std::byte(static_cast<std::uint8_t>(x * 255.0f));
        } else if (type == volume::ScalarType::U16) {
            auto w = static_cast<std::uint16_t>(x * 65535.0f);
            std::memcpy(&v.bytes[2 * i], &w, 2);
        } else {
            float f = x * 9.0f - 3.0f;
            std::memcpy(&v.bytes[4 * i], &f, 4);
        }
    }
    v.range_lo = type == volume::ScalarType::F32 ? -2.0f : 0.0f;
    v.range_hi = type == volume::ScalarType::U8 ? 255.0f : (type == volume::ScalarType::U16 ? 65535.0f : 5.0f);
    return v;
}

volume::DensityGrid random_grid(volume::Dims d, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-0.2f, 1.2f);  // also outside [0, 1]
    volume::DensityGrid g{d, vec3(1.0f), std::vector<float>(std::size_t{d.x} * d.y * d.z)};
    for (float& x : g.values) x = u(rng);
    g.values[g.values.size() / 2] = std::numeric_limits<float>::infinity();  // allowed in grids
    return g;
}

TransferFunction constant_alpha(float a) { return TransferFunction({{0.0f, vec4(1.0f, 1.0f, 1.0f, a)}}); }

std::vector<volume::Dims> test_dims() {
    return {{37, 29, 21}, {8, 8, 8}, {1, 1, 1}, {1, 45, 1}, {17, 1, 9}, {64, 16, 24}, {3, 70, 5}};
}

/// The classifiers every source runs through: device-expressible for float voxels.
struct Classifiers {
    std::vector<std::pair<std::string, volume::TransferFunctionAlpha>> tfs{
        {"ramp 0.2-0.6", volume::TransferFunctionAlpha(TransferFunction::ramp(0.2f, 0.6f, vec4(1.0f)))},
        {"ct preset, min alpha 1e-6", volume::TransferFunctionAlpha(TransferFunction::ct_bone_tissue(), 1e-6f)},
        {"steep 1024 entries", volume::TransferFunctionAlpha(TransferFunction::ramp(0.40f, 0.41f, vec4(1.0f), 1024))},
        {"none opaque", volume::TransferFunctionAlpha(constant_alpha(0.0f))},
        {"all opaque", volume::TransferFunctionAlpha(constant_alpha(1.0f))}};
    std::vector<volume::DensityThreshold> thresholds{{0.1f}, {0.3f}, {0.0f}, {1.5f}};
};

/// Checks the device pass against the three references for one source and classifier.
template <class Source, class C>
void check_pass(vk::Context& ctx, const Source& src, const C& classify, vk::LocalBoxPassConfig pcfg = {}) {
    SerialExecutor serial;
    vk::LocalBoxPass pass(ctx, src, pcfg);
    kdtree::BoxClassifier bc = kdtree::box_classifier(kdtree::BoxSource::of(src), classify);
    std::vector<std::uint32_t> gpu;
    pass.block_words(bc, gpu);
    REQUIRE(gpu == kdtree::reference_block_words(kdtree::BoxSource::of(src), bc));

    auto host_src = volume::classified(src, classify);
    LocalBoxes host = kdtree::local_boxes(host_src, serial), dev = pass.local_boxes(classify);
    CHECK(dev.dims == host.dims);
    CHECK(dev.blocks == host.blocks);
    CHECK(dev.spacing == host.spacing);
    CHECK(dev.occupied == host.occupied);
    REQUIRE(dev.codes == host.codes);
    REQUIRE(dev.boxes == host.boxes);

    Occupancy occ = volume::classify(host_src, serial);  // brute force per block
    kdtree::BlockOrder order = kdtree::BlockOrder::of(src.dims);
    std::uint64_t total = 0;
    for (std::uint32_t i = 0; i < gpu.size(); ++i) {
        uvec3 b = order.coord(i);
        VoxelBox block{b * 8u, glm::min(b * 8u + 8u, uvec3(src.dims))};
        REQUIRE(kdtree::block_word_box(b, gpu[i]) == tight_direct(occ, block));
        REQUIRE(shared::sylva_kd_box_word_count(gpu[i]) == count_direct(occ, block));
        total += count_direct(occ, block);
    }
    CHECK(total == occ.count());
}

}  // namespace

TEST_CASE("device local boxes of uint8, uint16 and float32 volumes", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    Classifiers cl;
    std::uint32_t seed = 1;
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        for (volume::Dims d : test_dims()) {
            volume::Volume v = random_volume(d, type, seed++);
            for (const auto& [name, tf] : cl.tfs) {
                INFO(volume::scalar_name(type) << " " << d.x << "x" << d.y << "x" << d.z << ", " << name);
                check_pass(ctx, v, tf);
            }
            for (const auto& th : cl.thresholds) {
                INFO(volume::scalar_name(type) << " " << d.x << "x" << d.y << "x" << d.z << ", threshold " << th.min_density);
                check_pass(ctx, v, th);
            }
        }
    }
}

TEST_CASE("device local boxes of integer volumes under any classifier", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    auto band = [](float d) { return d > 0.2f && d < 0.45f; };  // a user classifier: table only
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        volume::Volume v = random_volume({37, 29, 21}, type, 40, 0.4);
        v.range_lo = 10.0f;  // a range other than the type's: the table normalises as the host does
        v.range_hi = type == volume::ScalarType::U8 ? 200.0f : 60000.0f;
        INFO(volume::scalar_name(type));
        check_pass(ctx, v, band);
        check_pass(ctx, v, volume::DensityThreshold{0.5f});
    }
}

TEST_CASE("device local boxes of density grids and occupancies", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    Classifiers cl;
    std::uint32_t seed = 100;
    for (volume::Dims d : test_dims()) {
        volume::DensityGrid g = random_grid(d, seed++);
        for (const auto& [name, tf] : cl.tfs) {
            INFO("grid " << d.x << "x" << d.y << "x" << d.z << ", " << name);
            check_pass(ctx, g, tf);
        }
        for (const auto& th : cl.thresholds) check_pass(ctx, g, th);
        for (double p : {0.0, 0.05, 1.0}) {  // all-empty, sparse, all-full occupancies
            INFO("occupancy " << d.x << "x" << d.y << "x" << d.z << ", p " << p);
            Occupancy o = random_occupancy(d, p, seed++);
            SerialExecutor serial;
            vk::LocalBoxPass pass(ctx, o);
            LocalBoxes host = kdtree::local_boxes(o, serial), dev = pass.local_boxes(volume::DensityThreshold{});
            CHECK(dev.occupied == host.occupied);
            REQUIRE(dev.codes == host.codes);
            REQUIRE(dev.boxes == host.boxes);
            if (p == 1.0) CHECK(dev.boxes.size() == std::size_t{(d.x + 7) / 8} * ((d.y + 7) / 8) * ((d.z + 7) / 8));
            if (p == 0.0) CHECK(dev.boxes.empty());
        }
    }
}

TEST_CASE("a volume cut into several slabs gives the same boxes", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        volume::Volume v = random_volume({30, 22, 61}, type, 7);  // 8 block layers, the last partial
        std::size_t layer = std::size_t{30} * 22 * 8 * volume::scalar_bytes(type);
        for (std::size_t layers : {1, 3}) {
            INFO(volume::scalar_name(type) << ", " << layers << " layers a slab");
            vk::LocalBoxPassConfig pcfg{layers * layer};
            vk::LocalBoxPass pass(ctx, v, pcfg);
            CHECK(pass.slab_count() == (8 + layers - 1) / layers);
            check_pass(ctx, v, volume::TransferFunctionAlpha(TransferFunction::ramp(0.25f, 0.5f, vec4(1.0f))), pcfg);
        }
    }
}

TEST_CASE("block verdicts let the device skip blocks, words unchanged", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    SerialExecutor serial;
    for (auto type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        volume::Volume v = random_volume({37, 29, 21}, type, 21, 0.3);
        std::size_t bytes = volume::scalar_bytes(type);
        for (std::size_t i = 0; i < v.voxels(); ++i) {  // constant blocks (0, 0.5, 1) beside random ones
            std::uint32_t x = i % 37, y = (i / 37) % 29, z = i / (37 * 29), block = x / 8 + 5 * (y / 8 + 4 * (z / 8));
            if (block % 3 == 0) continue;
            volume::Volume level = random_volume({1, 1, 1}, type, 0, block % 3 == 1 ? 0.0 : 1.0);
            if (block % 4 == 0) std::memset(&level.bytes[0], 0, bytes);
            std::memcpy(&v.bytes[i * bytes], level.bytes.data(), bytes);
        }
        kdtree::BoxSource s = kdtree::BoxSource::of(v);
        kdtree::BlockValues values;
        kdtree::block_values(s, serial, values);
        vk::LocalBoxPass pass(ctx, v);
        for (float th : {0.2f, 0.5f, 0.95f}) {
            INFO(volume::scalar_name(type) << ", threshold " << th);
            volume::DensityThreshold c{th};
            kdtree::BoxClassifier bc = kdtree::box_classifier(s, c);
            std::vector<std::uint8_t> table, verdicts;
            std::vector<std::uint32_t> scratch, all, skipping;
            if (s.source != SYLVA_KD_BOX_SOURCE_F32) kdtree::value_table(s, c, table);
            kdtree::block_verdicts(s, values, c, table, scratch, verdicts);
            CHECK(std::count(verdicts.begin(), verdicts.end(), kdtree::kBlockRead) < std::ptrdiff_t(verdicts.size()));
            pass.block_words(bc, all);
            pass.block_words(bc, skipping, verdicts);
            REQUIRE(skipping == all);
            REQUIRE(skipping == kdtree::reference_block_words(s, bc, 1, verdicts));
            pass.block_words(bc, all);  // back to reading every block
            REQUIRE(skipping == all);
        }
    }
}

TEST_CASE("binned trees from device boxes equal those from host boxes", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    volume::SparseNbodyConfig nc;
    nc.blobs = 200;
    nc.halos = 5;
    nc.blob_sigma = 0.03f;
    volume::DensityGrid g = volume::sparse_nbody({61, 47, 38}, 9, nc);  // clustered: trees with depth
    volume::Volume v = random_volume(g.dims, volume::ScalarType::U8, 9);
    for (std::size_t i = 0; i < g.values.size(); ++i) v.bytes[i] = std::byte(static_cast<std::uint8_t>(g.values[i] * 255.0f));
    volume::TransferFunctionAlpha tf(TransferFunction::ramp(0.3f, 0.6f, vec4(1.0f)));
    vk::LocalBoxPass pass(ctx, v);
    LocalBoxes dev = pass.local_boxes(tf);
    for (const Config& cfg : {Config::shallow().binned(), Config::deep().binned(), Config::deep().binned(8)}) {
        kdtree::Tree a = kdtree::build(dev, cfg, pool), b = kdtree::build_binned(volume::classified(v, tf), cfg, pool);
        REQUIRE(a.nodes == b.nodes);
        REQUIRE(vk::build_binned(pass, tf, cfg, pool).nodes == b.nodes);
        CHECK(a.leaves == b.leaves);
        CHECK(a.stats.occupied == b.stats.occupied);
        CHECK(a.stats.leaf_volume == b.stats.leaf_volume);
        INFO(a.stats.occupied << " occupied, " << a.stats.leaf_volume << " in leaves");
        CHECK(a.nodes.size() > 1);
    }
}

TEST_CASE("vk::KdRebuilder gives kdtree::Rebuilder's trees over a replay", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    SerialExecutor serial;
    volume::Volume v = random_volume({40, 33, 27}, volume::ScalarType::F32, 11, 0.02);
    for (const Config& cfg : {Config::shallow().binned(), Config::deep().binned()}) {
        vk::KdRebuilder gpu(ctx, v, cfg, serial, vk::LocalBoxPassConfig{std::size_t{40} * 33 * 8 * 4});
        kdtree::Rebuilder host(v, cfg, serial);
        for (const TransferFunction& tf : {TransferFunction::ramp(0.3f, 0.6f, vec4(1.0f)), constant_alpha(0.0f),
                                           TransferFunction::ct_bone_tissue(), constant_alpha(1.0f)}) {
            kdtree::Tree a = gpu.rebuild(tf), b = host.rebuild(tf);
            REQUIRE(a.nodes == b.nodes);
            CHECK(a.leaves == b.leaves);
            CHECK(a.stats.occupied == b.stats.occupied);
            CHECK(gpu.pass_timings().readback_ms >= 0.0);
            CHECK(gpu.timings().blocks_read == host.timings().blocks_read);
        }
    }
}

TEST_CASE("device local boxes of the aneurism", "[parity][kd][data]") {
    std::filesystem::path p = testdata::require("aneurism_256x256x256_uint8.raw");  // fails (or skips) when missing
    vk::Context ctx = vk::Context::create();
    volume::Volume v = volume::read_raw(p, volume::parse_raw_name(p.filename().string()));
    ThreadPool pool(2);
    vk::LocalBoxPass pass(ctx, v);
    for (const auto& tf : {volume::TransferFunctionAlpha(TransferFunction::ramp(0.1f, 0.5f, vec4(1.0f))),
                           volume::TransferFunctionAlpha(TransferFunction::ct_bone_tissue(), 1e-6f)}) {
        LocalBoxes dev = pass.local_boxes(tf), host = kdtree::local_boxes(volume::classified(v, tf), pool);
        CHECK(dev.occupied == host.occupied);
        REQUIRE(dev.codes == host.codes);
        REQUIRE(dev.boxes == host.boxes);
    }
    LocalBoxes dev = pass.local_boxes(volume::DensityThreshold{0.1f});
    CHECK(dev.occupied == 113453u);  // Kinkelin Table 6 (docs/DESIGN.md, Data)
    kdtree::Tree a = kdtree::build(dev, Config::deep().binned(), pool);
    kdtree::Tree b = kdtree::build_binned(volume::classified(v, volume::DensityThreshold{0.1f}), Config::deep().binned(), pool);
    REQUIRE(a.nodes == b.nodes);
}

TEST_CASE("device local-box pass, bad input", "[parity][kd]") {
    vk::Context ctx = vk::Context::create();
    volume::Volume v = random_volume({20, 18, 17}, volume::ScalarType::F32, 5);
    float nan = std::nanf(""), inf = std::numeric_limits<float>::infinity();
    volume::Volume with_nan = v, with_inf = v;
    std::memcpy(&with_nan.bytes[4 * 777], &nan, 4);
    std::memcpy(&with_inf.bytes[4 * 3000], &inf, 4);
    volume::DensityThreshold th{0.3f};
    for (const volume::Volume* bad : {&with_nan, &with_inf}) {
        vk::LocalBoxPass pass(ctx, *bad);
        CHECK_THROWS_AS(pass.local_boxes(th), Error);
        SerialExecutor serial;
        CHECK_THROWS_AS(kdtree::local_boxes(volume::classified(*bad, th), serial), Error);  // the host agrees
    }
    volume::DensityGrid g = random_grid({9, 9, 9}, 3);
    g.values[5] = nan;
    vk::LocalBoxPass grid_pass(ctx, g);
    CHECK_THROWS_AS(grid_pass.local_boxes(th), Error);
    vk::LocalBoxPass pass(ctx, v);
    auto custom = [](float d) { return d > 0.5f; };  // float voxels: not expressible on the device
    CHECK_THROWS_AS(pass.local_boxes(custom), Error);
    CHECK_THROWS_AS(vk::LocalBoxPass(ctx, v, vk::LocalBoxPassConfig{100}), Error);  // one layer > a slab
    SerialExecutor serial;
    CHECK_THROWS_AS(vk::KdRebuilder(ctx, v, Config::deep(), serial), Error);  // Vidal planes: host only
    volume::Volume short_volume = v;
    short_volume.bytes.resize(short_volume.bytes.size() - 4);
    CHECK_THROWS_AS(vk::LocalBoxPass(ctx, short_volume), Error);
}
