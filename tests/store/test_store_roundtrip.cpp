// store.roundtrip: an in-core octree written as a store reads back with the same index, word for
// word, and every brick bit for bit, for every codec; faults are reported.
#include <catch2/catch.hpp>

#include <fstream>
#include <thread>
#include <vector>

#include <sylva/octree/brick_source.hpp>
#include <sylva/store/store.hpp>
#include <sylva/store/write_tree.hpp>
#include <sylva/volume/procedural.hpp>

#include "store_test_util.hpp"

using namespace sylva;
using sylva::testing::TempDir;

namespace {
octree::Tree small_tree(std::uint32_t b = 8, std::uint32_t border = 2) {
    return octree::build(volume::marschner_lobb({37, 21, 18}), {b, border});
}

/// Every brick of `s` equals the tree's.
template <class S>
void check_equal(const S& s, const octree::TreeBrickSource& ref) {
    REQUIRE(std::vector<std::uint32_t>(s.index().begin(), s.index().end()) ==
            std::vector<std::uint32_t>(ref.index().begin(), ref.index().end()));
    const std::uint32_t words = ref.index()[8], count = ref.index()[7];
    std::vector<std::uint32_t> a(words), b(words);
    for (std::uint32_t k = 0; k < count; ++k) {
        REQUIRE(s.read_brick(k, a) == octree::BrickStatus::ok);
        REQUIRE(ref.read_brick(k, b) == octree::BrickStatus::ok);
        REQUIRE(a == b);
    }
}
}  // namespace

TEST_CASE("a stored in-core tree reads back word for word, every codec and brick format", "[store]") {
    TempDir dir;
    for (auto f : {octree::BrickFormat::Float32, octree::BrickFormat::Unorm16, octree::BrickFormat::Unorm8})
    for (store::Codec c : {store::Codec::none, store::Codec::lz4, store::Codec::zstd}) {
        octree::TreeBrickSource ref(octree::build(volume::marschner_lobb({37, 21, 18}), {8, 2, f}));
        INFO(store::brick_format_name(f) << ", " << store::codec_name(c));
        auto path = dir / (std::string("t-") + store::codec_name(c) + "-" + store::brick_format_name(f));
        store::write_tree(ref.tree(), path, c, 3);
        store::Store s = store::Store::open(path);
        CHECK(s.complete());
        CHECK(s.build_info().brick_format == f);
        CHECK(s.brick_words() == ref.tree().brick_words());
        CHECK(s.brick_count() == ref.tree().nodes.size());
        check_equal(s, ref);
        std::vector<std::uint32_t> out(s.brick_words());
        CHECK(s.read_brick(s.brick_count(), out) == octree::BrickStatus::missing);
        std::vector<std::uint32_t> wrong(s.brick_words() + 1);
        CHECK(s.read_brick(0, wrong) == octree::BrickStatus::missing);
        CHECK(s.verify().ok());
    }
}

TEST_CASE("reads from several threads at once", "[store][concurrency]") {
    TempDir dir;
    octree::TreeBrickSource ref(small_tree());
    // A 1 GiB map instead of the default 1 TiB: under ThreadSanitizer (this test runs there,
    // label tsan) the 1 TiB mapping sometimes finds no room in the sanitizer's address-space
    // layout and mdb_env_open fails with ENOMEM, about one run in six on this machine.
    store::WriterConfig small_map;
    small_map.map_bytes = std::uint64_t{1} << 30;
    store::write_tree(ref.tree(), dir / "s", store::build_info_of(ref.tree(), "in-core octree", store::Codec::zstd, 1),
                      small_map);
    store::Store s = store::Store::open(dir / "s");
    std::atomic<int> bad{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            std::vector<std::uint32_t> a(s.brick_words()), b(s.brick_words());
            for (int round = 0; round < 20; ++round)
                for (std::uint32_t k = std::uint32_t(t); k < s.brick_count(); k += 3)
                    if (s.read_brick(k, a) != octree::BrickStatus::ok || ref.read_brick(k, b) != octree::BrickStatus::ok ||
                        a != b)
                        ++bad;
        });
    for (auto& th : threads) th.join();
    CHECK(bad == 0);
}

TEST_CASE("opening what is not a complete store fails with a message", "[store]") {
    TempDir dir;
    CHECK_THROWS_WITH(store::Store::open(dir / "nothing"), Catch::Contains("no such store"));
    std::filesystem::create_directories(dir / "empty");
    CHECK_THROWS_WITH(store::Store::open(dir / "empty"), Catch::Contains("no such store"));
    octree::Tree t = small_tree();
    store::write_tree(t, dir / "s");
    CHECK_THROWS_WITH(store::write_tree(t, dir / "s"), Catch::Contains("never overwritten"));
}
