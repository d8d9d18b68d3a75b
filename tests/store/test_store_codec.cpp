// store.codec: every codec gives back the brick's float bits exactly; damaged stored bricks
// (flipped bytes, truncation, bad headers) are reported, never read out of bounds.
#include <catch2/catch.hpp>

#include <bit>
#include <cstdint>
#include <random>
#include <vector>

#include <sylva/store/codec.hpp>
#include <sylva/store/format.hpp>

using namespace sylva::store;

namespace {
/// A brick of smooth densities with a few special float values (denormal, -0, 1).
std::vector<std::uint32_t> sample_brick(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<std::uint32_t> w(n);
    float v = 0.5f;
    for (std::size_t i = 0; i < n; ++i) {
        v = std::min(1.0f, std::max(0.0f, v + 0.01f * (u(rng) - 0.5f)));
        w[i] = std::bit_cast<std::uint32_t>(v);
    }
    const std::uint32_t special[3] = {std::bit_cast<std::uint32_t>(-0.0f), 1u /* denormal */,
                                      std::bit_cast<std::uint32_t>(1.0f)};
    for (std::size_t i = 0; i < 3 && i < n; ++i) w[i] = special[i];  // bricks of 1 word too
    return w;
}
}  // namespace

TEST_CASE("every codec round trips a brick bit for bit", "[store]") {
    for (Codec c : {Codec::none, Codec::lz4, Codec::zstd}) {
        for (std::size_t n : {std::size_t{8000}, std::size_t{36 * 36 * 36}, std::size_t{1}}) {
            std::vector<std::uint32_t> w = sample_brick(n, unsigned(n)), back(n, 0xDEADBEEFu);
            std::vector<std::byte> enc;
            encode_brick(w, c, 3, enc);
            CHECK(decode_brick(enc, back) == DecodeStatus::ok);
            CHECK(back == w);
            CHECK(stored_checksum(enc) == brick_checksum(w));
        }
    }
}

TEST_CASE("a constant brick compresses to a fraction of its size", "[store]") {
    std::vector<std::uint32_t> w(36 * 36 * 36, std::bit_cast<std::uint32_t>(0.25f));
    std::vector<std::byte> enc;
    encode_brick(w, Codec::zstd, 1, enc);
    CHECK(enc.size() < w.size() * 4 / 100);
    encode_brick(w, Codec::lz4, 0, enc);
    CHECK(enc.size() < w.size() * 4 / 50);
}

TEST_CASE("damaged stored bricks are reported, never decoded as good", "[store]") {
    const std::size_t n = 20 * 20 * 20;
    std::vector<std::uint32_t> w = sample_brick(n, 7), back(n);
    for (Codec c : {Codec::none, Codec::lz4, Codec::zstd}) {
        std::vector<std::byte> enc;
        encode_brick(w, c, 1, enc);
        INFO(codec_name(c));
        SECTION("every truncation") {
            for (std::size_t len = 0; len < enc.size(); len += 1 + len / 16)
                CHECK(decode_brick(std::span<const std::byte>(enc.data(), len), back) != DecodeStatus::ok);
        }
        SECTION("a flipped byte anywhere") {
            std::mt19937 rng(11);
            for (int t = 0; t < 300; ++t) {
                std::vector<std::byte> bad = enc;
                std::size_t at = rng() % bad.size();
                bad[at] ^= std::byte(1u << (rng() % 8));
                CHECK(decode_brick(bad, back) != DecodeStatus::ok);
            }
        }
        SECTION("a wrong brick size") {
            std::vector<std::uint32_t> small(n - 1);
            CHECK(decode_brick(enc, small) == DecodeStatus::bad_header);
        }
    }
}

TEST_CASE("codec names", "[store]") {
    CHECK(codec_from_name("zstd") == Codec::zstd);
    CHECK(codec_from_name("lz4") == Codec::lz4);
    CHECK(codec_from_name("none") == Codec::none);
    CHECK_THROWS_WITH(codec_from_name("lzo"), Catch::Contains("unknown codec 'lzo'"));
}

TEST_CASE("the build record refuses zstd levels outside -5 .. 19 (fuzz_store_build_info)", "[store][fuzz]") {
    // "level=-2147483648" used to negate INT_MIN (undefined behaviour, found by
    // fuzz_store_build_info; input in tests/fuzz_regressions/store_build_info/).
    using namespace sylva::store;
    BuildInfo b;
    b.input = "procedural:ml:64";
    b.dims = sylva::volume::Dims(64u);
    std::string good = to_text(b);
    REQUIRE(build_info_from_text(good) == b);
    for (const char* level : {"-5", "19", "-1"}) {
        std::string t = good;
        t.replace(t.find("level=1"), 7, std::string("level=") + level);
        CHECK(build_info_from_text(t).level == std::stoi(level));
    }
    for (const char* level : {"-2147483648", "2147483648", "20", "-20", "4294967295"}) {
        std::string t = good;
        t.replace(t.find("level=1"), 7, std::string("level=") + level);
        INFO(level);
        CHECK_THROWS_AS(build_info_from_text(t), sylva::Error);
    }
}
