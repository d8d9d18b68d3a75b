// store.faults: damaged stores are reported, never crash and never hand out wrong bricks --
// flipped bytes and truncated values in stored bricks (read_brick: corrupt; verify lists the
// keys), a truncated data.mdb, a newer format version, a full map (DiskFullError, store left
// incomplete; resume finishes it to the same content).
#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <sylva/store/store.hpp>
#include <sylva/store/stream_build.hpp>
#include <sylva/store/write_tree.hpp>
#include <sylva/volume/procedural.hpp>

#include "store_test_util.hpp"

using namespace sylva;
using sylva::testing::TempDir;

namespace {

/// Opens the store's LMDB environment for writing and replaces the value of `key` in database
/// `db` by what `edit` makes of it (a valid LMDB write: only the stored brick is damaged).
template <class F>
void edit_value(const std::filesystem::path& path, const char* db, const std::string& key_bytes, F edit) {
    store::lmdb::Env env("test");
    store::lmdb::check(mdb_env_set_maxdbs(env.get(), 4), "test", "maxdbs");
    store::lmdb::check(mdb_env_open(env.get(), path.c_str(), 0, 0644), "test", "open");
    store::lmdb::Txn txn(env, 0);
    MDB_dbi dbi;
    store::lmdb::check(mdb_dbi_open(txn.get(), db, std::string(db) == "bricks" ? MDB_INTEGERKEY : 0, &dbi), "test", "dbi");
    MDB_val k = store::lmdb::val(key_bytes.data(), key_bytes.size()), v;
    REQUIRE(mdb_get(txn.get(), dbi, &k, &v) == MDB_SUCCESS);
    std::vector<std::byte> bytes(static_cast<std::byte*>(v.mv_data), static_cast<std::byte*>(v.mv_data) + v.mv_size);
    edit(bytes);
    v = store::lmdb::val(bytes.data(), bytes.size());
    store::lmdb::check(mdb_put(txn.get(), dbi, &k, &v, 0), "test", "put");
    REQUIRE(txn.commit() == MDB_SUCCESS);
}

/// Replaces `from` by `to` in the store's build info text (the first occurrence, which must exist).
void edit_build_info(const std::filesystem::path& path, const std::string& from, const std::string& to) {
    edit_value(path, "meta", "build", [&](std::vector<std::byte>& b) {
        std::string text(reinterpret_cast<const char*>(b.data()), b.size());
        std::size_t at = text.find(from);
        REQUIRE(at != std::string::npos);
        text.replace(at, from.size(), to);
        const auto* p = reinterpret_cast<const std::byte*>(text.data());
        b.assign(p, p + text.size());
    });
}

std::string key_of(unsigned k) { return std::string(reinterpret_cast<const char*>(&k), sizeof k); }

octree::Tree tree() { return octree::build(volume::marschner_lobb({40, 30, 20}), {8, 2}); }

}  // namespace

TEST_CASE("a flipped byte or a truncated value in a stored brick is reported, per codec", "[store]") {
    octree::Tree t = tree();
    for (store::Codec c : {store::Codec::none, store::Codec::lz4, store::Codec::zstd}) {
        INFO(store::codec_name(c));
        TempDir dir;
        store::write_tree(t, dir / "s", c, 1);
        std::mt19937 rng(5);
        edit_value(dir / "s", "bricks", key_of(3), [&](std::vector<std::byte>& b) {
            b[store::kBrickHeaderBytes + rng() % (b.size() - store::kBrickHeaderBytes)] ^= std::byte{0x10};
        });
        edit_value(dir / "s", "bricks", key_of(7), [](std::vector<std::byte>& b) { b.resize(b.size() / 2); });
        edit_value(dir / "s", "bricks", key_of(9), [](std::vector<std::byte>& b) { b.resize(5); });
        edit_value(dir / "s", "bricks", key_of(11), [](std::vector<std::byte>& b) { b[9] ^= std::byte{1}; });  // checksum
        store::Store s = store::Store::open(dir / "s");
        std::vector<std::uint32_t> out(s.brick_words());
        for (std::uint32_t k : {3u, 7u, 9u, 11u}) CHECK(s.read_brick(k, out) == octree::BrickStatus::corrupt);
        CHECK(s.read_brick(4, out) == octree::BrickStatus::ok);
        store::VerifyReport r = s.verify();
        CHECK_FALSE(r.ok());
        CHECK(r.corrupt == std::vector<std::uint32_t>{3, 7, 9, 11});
        CHECK(r.missing == 0);
    }
}

TEST_CASE("a truncated data.mdb is refused at open, not read past its end", "[store]") {
    TempDir dir;
    store::write_tree(tree(), dir / "s", store::Codec::none, 0);
    auto file = dir / "s" / "data.mdb";
    std::filesystem::resize_file(file, std::filesystem::file_size(file) / 2);
    CHECK_THROWS_AS(store::Store::open(dir / "s"), Error);
    std::filesystem::resize_file(file, 100);
    CHECK_THROWS_AS(store::Store::open(dir / "s"), Error);
}

TEST_CASE("a store of a newer format version is refused with a message", "[store]") {
    TempDir dir;
    store::write_tree(tree(), dir / "s");
    edit_value(dir / "s", "meta", "format", [](std::vector<std::byte>& b) {
        std::uint32_t v = store::kFormatVersion + 1;
        std::memcpy(b.data(), &v, 4);
    });
    CHECK_THROWS_WITH(store::Store::open(dir / "s"),
                      Catch::Contains("format version " + std::to_string(store::kFormatVersion + 1) + " is newer"));
    CHECK_THROWS_WITH(store::Store::open(dir / "s", true), Catch::Contains("newer"));
}

TEST_CASE("a damaged index is refused", "[store]") {
    TempDir dir;
    store::write_tree(tree(), dir / "s");
    edit_value(dir / "s", "meta", "index", [](std::vector<std::byte>& b) { b[100] ^= std::byte{4}; });
    CHECK_THROWS_WITH(store::Store::open(dir / "s"), Catch::Contains("index fails its checksum"));
}

TEST_CASE("a full map stops the build with the space needed; resume finishes the same store", "[store]") {
    TempDir dir;
    ThreadPool pool(2);
    store::StreamConfig cfg;
    cfg.octree = {8, 2};
    cfg.codec = store::Codec::none;  // 8000 words a brick: a 1 MiB map holds a few dozen
    cfg.writer.map_bytes = 1u << 20;
    cfg.writer.batch_bricks = 4;
    store::MarschnerLobbSlices src({40, 40, 40});
    CHECK_THROWS_AS(store::build_store(src, "ml", dir / "s", cfg, pool), store::DiskFullError);
    try {
        store::MarschnerLobbSlices again({40, 40, 40});
        cfg.resume = true;
        store::build_store(again, "ml", dir / "s", cfg, pool);
        FAIL("a second build into the same 1 MiB map must fail too");
    } catch (const store::DiskFullError& e) {
        CHECK_THAT(e.what(), Catch::Contains("more are needed") && Catch::Contains("--resume"));
    }
    CHECK_THROWS_WITH(store::Store::open(dir / "s"), Catch::Contains("incomplete"));
    store::Store partial = store::Store::open(dir / "s", true);
    CHECK(partial.bricks_stored() > 0);
    CHECK(partial.bricks_stored() < partial.brick_count());
    store::VerifyReport r = partial.verify();
    CHECK_FALSE(r.ok());
    CHECK(r.corrupt.empty());
    CHECK(r.missing == partial.brick_count() - partial.bricks_stored());

    cfg.writer.map_bytes = 64u << 20;
    store::MarschnerLobbSlices third({40, 40, 40});
    store::StreamResult res = store::build_store(third, "ml", dir / "s", cfg, pool);
    CHECK(res.bricks_skipped == partial.bricks_stored());
    store::Store done = store::Store::open(dir / "s");
    CHECK(done.verify().ok());
    store::write_tree(octree::build(volume::marschner_lobb({40, 40, 40}), {8, 2}), dir / "ref",
                      store::build_info_of(octree::build(volume::marschner_lobb({40, 40, 40}), {8, 2}), "ml",
                                           store::Codec::none, 0));
    CHECK(done.content_digest() == store::Store::open(dir / "ref").content_digest());
}

TEST_CASE("resume refuses an interrupted store of other settings or input", "[store]") {
    TempDir dir;
    ThreadPool pool(1);
    store::StreamConfig cfg;
    cfg.octree = {8, 2};
    cfg.codec = store::Codec::none;
    cfg.writer.map_bytes = 1u << 20;  // stops early: an incomplete store
    store::MarschnerLobbSlices a({40, 40, 40});
    CHECK_THROWS_AS(store::build_store(a, "ml", dir / "s", cfg, pool), store::DiskFullError);
    cfg.writer.map_bytes = 64u << 20;
    cfg.resume = true;
    store::StreamConfig other = cfg;
    other.octree = {16, 2};
    store::MarschnerLobbSlices b({40, 40, 40});
    CHECK_THROWS_WITH(store::build_store(b, "ml", dir / "s", other, pool), Catch::Contains("other settings"));
    store::MarschnerLobbSlices c({40, 40, 41});
    CHECK_THROWS_WITH(store::build_store(c, "ml", dir / "s", cfg, pool), Catch::Contains("other settings"));
    store::MarschnerLobbSlices d({40, 40, 40});
    CHECK_THROWS_WITH(store::build_store(d, "other input", dir / "s", cfg, pool), Catch::Contains("other settings"));
    store::MarschnerLobbSlices e({40, 40, 40});
    store::build_store(e, "ml", dir / "s", cfg, pool);
    CHECK(store::Store::open(dir / "s").verify().ok());
}

TEST_CASE("resume refuses other settings and finished stores", "[store]") {
    TempDir dir;
    ThreadPool pool(1);
    store::StreamConfig cfg;
    cfg.octree = {8, 1};
    store::MarschnerLobbSlices a({20, 20, 20});
    store::build_store(a, "ml", dir / "s", cfg, pool);
    cfg.resume = true;
    store::MarschnerLobbSlices b({20, 20, 20});
    CHECK_THROWS_WITH(store::build_store(b, "ml", dir / "s", cfg, pool), Catch::Contains("already complete"));
    CHECK(store::Store::open(dir / "s").verify().ok());
    std::filesystem::create_directories(dir / "user");
    std::ofstream(dir / "user" / "notes.txt") << "mine";
    store::MarschnerLobbSlices c({20, 20, 20});
    CHECK_THROWS_WITH(store::build_store(c, "ml", dir / "user", cfg, pool), Catch::Contains("not a brick store"));
    CHECK(std::filesystem::exists(dir / "user" / "notes.txt"));
}

TEST_CASE("a tree whose brick format differs from its build info is refused and nothing written", "[store][bad-input]") {
    octree::Tree t = octree::build(volume::marschner_lobb({40, 30, 20}), {8, 2, octree::BrickFormat::Unorm8});
    TempDir dir;
    store::BuildInfo info = store::build_info_of(t, "t", store::Codec::zstd, 1);
    info.brick_format = octree::BrickFormat::Float32;
    CHECK_THROWS_WITH(store::write_tree(t, dir / "s", info), Catch::Contains("the tree's bricks are unorm8"));
    CHECK_FALSE(std::filesystem::exists(dir / "s"));
}

TEST_CASE("a version-1 store (float32 bricks, no brick_format line) still reads", "[store]") {
    TempDir dir;
    octree::Tree t = tree();
    store::write_tree(t, dir / "s");
    edit_value(dir / "s", "meta", "format", [](std::vector<std::byte>& b) {
        std::uint32_t v = 1;
        std::memcpy(b.data(), &v, 4);
    });
    edit_build_info(dir / "s", "brick_format=float32\n", "");
    store::Store s = store::Store::open(dir / "s");
    CHECK(s.format_version() == 1u);
    CHECK(s.build_info().brick_format == octree::BrickFormat::Float32);
    std::vector<std::uint32_t> out(s.brick_words());
    for (std::uint32_t k = 0; k < s.brick_count(); ++k) REQUIRE(s.read_brick(k, out) == octree::BrickStatus::ok);
    CHECK(s.verify().ok());
}

TEST_CASE("build info whose brick format contradicts the index is refused", "[store]") {
    TempDir dir;
    // unorm16 bricks labelled float32: the index's format and brick word count disagree.
    store::write_tree(octree::build(volume::marschner_lobb({40, 30, 20}), {8, 2, octree::BrickFormat::Unorm16}), dir / "a");
    edit_build_info(dir / "a", "brick_format=unorm16", "brick_format=float32");
    CHECK_THROWS_WITH(store::Store::open(dir / "a"), Catch::Contains("does not match the build info"));
    store::write_tree(tree(), dir / "b");
    edit_build_info(dir / "b", "brick_format=float32", "brick_format=unorm12");
    CHECK_THROWS_WITH(store::Store::open(dir / "b"), Catch::Contains("bad brick_format"));
}
