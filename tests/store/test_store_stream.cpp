// store.stream: the streamed builder (slice windows) writes exactly what octree::build +
// octree::encode give for the same volume: the index word for word, every brick bit for bit;
// over odd, non-cubic, non-power-of-two sizes, uint8/uint16/float32 raw files, B = 16 and 32
// (and 4, 8 for deep trees), borders 1 and 2, Marschner-Lobb generated slice by slice, a
// resampled volume, and the aneurism of ../shared/data; float32, unorm16 and unorm8 bricks.
#include <catch2/catch.hpp>

#include <bit>
#include <cstring>
#include <fstream>
#include <random>
#include <vector>

#include <sylva/octree/brick_source.hpp>
#include <sylva/store/store.hpp>
#include <sylva/store/stream_build.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/resample.hpp>

#include "../missing_data.hpp"
#include "store_test_util.hpp"

using namespace sylva;
using sylva::testing::TempDir;

namespace {

/// The store at `path` equals the in-core octree of `grid` under `cfg`, word for word.
void check_store_equals_in_core(const std::filesystem::path& path, const volume::DensityGrid& grid,
                                const octree::Config& cfg) {
    octree::TreeBrickSource ref(octree::build(grid, cfg));
    store::Store s = store::Store::open(path);
    std::span<const std::uint32_t> a = s.index(), b = ref.index();
    REQUIRE(a.size() == b.size());
    std::size_t diff = 0;
    for (std::size_t i = 0; i < a.size(); ++i) diff += a[i] != b[i];
    REQUIRE(diff == 0);
    std::vector<std::uint32_t> x(s.brick_words()), y(s.brick_words());
    std::size_t bad = 0;
    for (std::uint32_t k = 0; k < s.brick_count(); ++k) {
        REQUIRE(s.read_brick(k, x) == octree::BrickStatus::ok);
        REQUIRE(ref.read_brick(k, y) == octree::BrickStatus::ok);
        bad += x != y;
    }
    CHECK(bad == 0);
    CHECK(s.verify().ok());
}

store::StreamResult stream(store::SliceSource& src, const std::filesystem::path& path, std::uint32_t b,
                           std::uint32_t border, store::Codec codec = store::Codec::zstd,
                           octree::BrickFormat format = octree::BrickFormat::Float32) {
    ThreadPool pool(2);
    store::StreamConfig cfg;
    cfg.octree = {b, border, format};
    cfg.codec = codec;
    cfg.batch_bricks = 5;  // several batches per row
    return store::build_store(src, "test", path, cfg, pool);
}

/// A raw file of random-walk voxels of type T named NAME_XxYxZ_TYPE.raw; returns its path.
template <class T>
std::filesystem::path write_raw(const std::filesystem::path& dir, volume::Dims d, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<T> v(std::size_t(d.x) * d.y * d.z);
    double x = 0.3;
    for (T& t : v) {
        x = std::clamp(x + (double(rng() % 1000) / 1000.0 - 0.5) * 0.1, 0.0, 1.0);
        if constexpr (std::is_floating_point_v<T>) t = T(x * 1000.0 - 200.0);
        else t = T(x * double(std::numeric_limits<T>::max()) * 0.8);
    }
    const char* type = sizeof(T) == 1 ? "uint8" : (sizeof(T) == 2 ? "uint16" : "float32");
    auto p = dir / ("v_" + std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z) + "_" + type + ".raw");
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
    return p;
}

template <class T>
void check_raw(volume::Dims d, std::uint32_t b, std::uint32_t border, const volume::ValueRange& range = {},
               octree::BrickFormat format = octree::BrickFormat::Float32) {
    TempDir dir;
    auto file = write_raw<T>(dir.path(), d, d.x * 7 + d.y);
    store::RawFileSlices src(file, volume::parse_raw_name(file.filename().string()), range);
    store::StreamResult r = stream(src, dir / "s", b, border, store::Codec::zstd, format);
    CHECK(r.bricks_written == r.info.node_count);
    CHECK(r.info.brick_format == format);
    volume::Volume v = volume::read_volume(file, std::nullopt, range);
    CHECK(src.range_lo() == v.range_lo);
    CHECK(src.range_hi() == v.range_hi);
    check_store_equals_in_core(dir / "s", volume::normalize(v), {b, border, format});
}

}  // namespace

TEST_CASE("streamed Marschner-Lobb equals the in-core octree", "[store]") {
    struct Case {
        volume::Dims d;
        std::uint32_t b, border;
    };
    for (Case c : {Case{{37, 21, 18}, 4, 1}, Case{{37, 21, 18}, 8, 2}, Case{{50, 33, 71}, 16, 2}, Case{{50, 33, 71}, 16, 1},
                   Case{{65, 40, 33}, 32, 2}, Case{{65, 40, 33}, 32, 1}, Case{{1, 1, 1}, 4, 1}, Case{{5, 1, 70}, 4, 2}}) {
        INFO(c.d.x << "x" << c.d.y << "x" << c.d.z << " B=" << c.b << " border=" << c.border);
        TempDir dir;
        store::MarschnerLobbSlices src(c.d);
        stream(src, dir / "s", c.b, c.border);
        check_store_equals_in_core(dir / "s", volume::marschner_lobb(c.d), {c.b, c.border});
    }
}

TEST_CASE("streamed raw files equal read_raw + normalize + build, every type", "[store]") {
    check_raw<std::uint8_t>({45, 30, 19}, 16, 2);
    check_raw<std::uint16_t>({33, 17, 40}, 16, 1);
    check_raw<float>({31, 29, 35}, 8, 2);
    check_raw<std::uint16_t>({40, 33, 35}, 32, 2, volume::ValueRange::of_type());
    check_raw<std::uint8_t>({20, 21, 22}, 8, 1, volume::ValueRange::between(10.0f, 120.0f));
}

TEST_CASE("unorm16 and unorm8 bricks stream as octree::build rounds them, every type", "[store]") {
    using F = octree::BrickFormat;
    check_raw<std::uint16_t>({33, 17, 40}, 16, 1, {}, F::Unorm16);
    check_raw<std::uint16_t>({40, 33, 35}, 32, 2, volume::ValueRange::of_type(), F::Unorm16);
    check_raw<std::uint8_t>({45, 30, 19}, 16, 2, {}, F::Unorm16);
    check_raw<std::uint8_t>({20, 21, 22}, 8, 1, volume::ValueRange::between(10.0f, 120.0f), F::Unorm8);
    check_raw<float>({31, 29, 35}, 8, 2, {}, F::Unorm16);
    for (F f : {F::Unorm16, F::Unorm8}) {
        TempDir dir;
        store::MarschnerLobbSlices src({37, 21, 18});
        stream(src, dir / "s", 4, 2, store::Codec::lz4, f);
        check_store_equals_in_core(dir / "s", volume::marschner_lobb({37, 21, 18}), {4, 2, f});
    }
}

TEST_CASE("a uint16 volume over its type's range loses nothing in unorm16 bricks", "[store]") {
    // Level 0's samples are the voxels themselves: q = v exactly, so the finest bricks hold the
    // file's values; coarser levels are rounded averages (octree::build's, checked above).
    TempDir dir;
    auto file = write_raw<std::uint16_t>(dir.path(), {21, 19, 17}, 5);
    store::RawFileSlices src(file, volume::parse_raw_name(file.filename().string()), volume::ValueRange::of_type());
    stream(src, dir / "s", 8, 2, store::Codec::zstd, octree::BrickFormat::Unorm16);
    std::vector<std::uint16_t> raw(21 * 19 * 17);
    std::ifstream(file, std::ios::binary).read(reinterpret_cast<char*>(raw.data()), std::streamsize(raw.size() * 2));
    store::Store s = store::Store::open(dir / "s");
    octree::Tree t = octree::build(volume::normalize(volume::read_volume(file, std::nullopt, volume::ValueRange::of_type())),
                                   {8, 2, octree::BrickFormat::Unorm16});
    std::vector<std::uint32_t> words(s.brick_words());
    std::size_t checked = 0, wrong = 0;
    for (const octree::Node& n : t.nodes) {
        if (n.level != t.levels - 1u) continue;
        REQUIRE(s.read_brick(n.brick, words) == octree::BrickStatus::ok);
        const std::uint32_t side = t.brick_side();
        for (std::uint32_t z = 0; z < side; ++z)
            for (std::uint32_t y = 0; y < side; ++y)
                for (std::uint32_t x = 0; x < side; ++x) {
                    glm::ivec3 v = glm::clamp(glm::ivec3(n.coord * t.brick_size) - 2 + glm::ivec3(x, y, z), glm::ivec3(0),
                                              glm::ivec3(20, 18, 16));
                    std::uint32_t i = x + side * (y + side * z);
                    std::uint32_t q = (words[i / 2] >> ((i % 2) * 16)) & 0xFFFFu;
                    wrong += q != raw[std::size_t(v.x) + 21u * (std::size_t(v.y) + 19u * std::size_t(v.z))];
                    ++checked;
                }
    }
    CHECK(checked > 21u * 19u * 17u);
    CHECK(wrong == 0);
}

TEST_CASE("sylva-store's default brick format: unorm16 for integer volumes, float32 for float ones", "[store]") {
    CHECK(store::default_brick_format("uint8") == octree::BrickFormat::Unorm16);
    CHECK(store::default_brick_format("uint16") == octree::BrickFormat::Unorm16);
    CHECK(store::default_brick_format("float32") == octree::BrickFormat::Float32);
    CHECK(store::brick_format_from_name("unorm8") == octree::BrickFormat::Unorm8);
    CHECK_THROWS_WITH(store::brick_format_from_name("half"), Catch::Contains("unknown brick format 'half'"));
}

TEST_CASE("every codec streams the same store", "[store]") {
    TempDir dir;
    std::uint64_t digest = 0;
    for (store::Codec c : {store::Codec::none, store::Codec::lz4, store::Codec::zstd}) {
        store::MarschnerLobbSlices src({29, 30, 31});
        auto p = dir / store::codec_name(c);
        stream(src, p, 8, 2, c);
        check_store_equals_in_core(p, volume::marschner_lobb({29, 30, 31}), {8, 2});
        std::uint64_t d = store::Store::open(p).content_digest();
        if (digest) CHECK(d == digest);
        digest = d;
    }
}

TEST_CASE("streamed resampling equals resample_trilinear + build", "[store]") {
    TempDir dir;
    volume::DensityGrid g = volume::marschner_lobb({13, 11, 9});
    auto src = std::make_unique<store::GridSlices>(g);
    store::ResampledSlices up(std::move(src), 2.5f);
    stream(up, dir / "s", 8, 2);
    SerialExecutor serial;
    check_store_equals_in_core(dir / "s", volume::resample_trilinear(g, 2.5f, serial), {8, 2});
}

TEST_CASE("bad input is refused before a store exists", "[store]") {
    TempDir dir;
    volume::RawInfo info{{10, 10, 10}, volume::ScalarType::U8, vec3(1.0f)};
    std::ofstream(dir / "short_10x10x10_uint8.raw", std::ios::binary).write("abc", 3);
    CHECK_THROWS_WITH(store::RawFileSlices(dir / "short_10x10x10_uint8.raw", info), Catch::Contains("truncated"));
    std::vector<float> nan(8, 0.5f);
    nan[5] = std::numeric_limits<float>::quiet_NaN();
    std::ofstream(dir / "n_2x2x2_float32.raw", std::ios::binary).write(reinterpret_cast<const char*>(nan.data()), 32);
    CHECK_THROWS_WITH(store::RawFileSlices(dir / "n_2x2x2_float32.raw", {{2, 2, 2}, volume::ScalarType::F32, vec3(1.0f)}),
                      Catch::Contains("voxel 5 is NaN"));
    CHECK_THROWS_WITH(store::MarschnerLobbSlices({0, 4, 4}), Catch::Contains("zero extent"));
    store::MarschnerLobbSlices absurd({1u << 25, 4, 4});
    ThreadPool pool(1);
    CHECK_THROWS_WITH(store::build_store(absurd, "absurd", dir / "a", {}, pool), Catch::Contains("2^24 - 1"));
    CHECK_FALSE(std::filesystem::exists(dir / "a"));
    store::MarschnerLobbSlices big({512, 512, 512});
    store::StreamConfig tight;
    tight.memory_bytes = 16u << 20;
    CHECK_THROWS_WITH(store::build_store(big, "big", dir / "b", tight, pool), Catch::Contains("more than --memory"));
    CHECK_FALSE(std::filesystem::exists(dir / "b"));
}

TEST_CASE("the streamed aneurism equals the in-core octree", "[store][data]") {
    auto file = sylva::testdata::dir() / "aneurism_256x256x256_uint8.raw";
    if (!std::filesystem::exists(file)) sylva::testdata::missing(file);
    TempDir dir;
    store::RawFileSlices src(file, volume::parse_raw_name(file.filename().string()));
    stream(src, dir / "s", 32, 2);
    check_store_equals_in_core(dir / "s", volume::normalize(volume::read_volume(file)), {32, 2});
}
