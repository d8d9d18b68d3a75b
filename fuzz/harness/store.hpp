// fuzz/harness/store.hpp -- harnesses of the out-of-core brick store's decoders (issue 16,
// sylva/store/): a stored brick (header, zstd / lz4 / plain payload, byte shuffle, XXH3
// checksum) and the store's "build" record. These are the bytes the store reads back from disk;
// the LMDB file itself is LMDB's (its own page checks), and the index it holds is an octree
// encoding, covered by fuzz_octree. Bad input must be refused (a DecodeStatus, a
// sylva::Error); a crash, a sanitizer report, a brick accepted whose words do not match its
// checksum, or a record that does not round trip is a finding.
#ifndef SYLVA_FUZZ_HARNESS_STORE_HPP
#define SYLVA_FUZZ_HARNESS_STORE_HPP

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <sylva/core/error.hpp>
#include <sylva/store/codec.hpp>
#include <sylva/store/format.hpp>

#include "common.hpp"

namespace sylva_fuzz {

/// Words a fuzzed brick decodes into: the size its header claims when that is a plausible
/// brick (1 .. 2^18 words; the largest real one, B = 32 with border 2, is 46,656), else the
/// input's low bits pick one, so both the header check and the decompressors are reached.
inline std::size_t fuzz_brick_words(std::span<const std::byte> stored) {
    if (stored.size() >= sylva::store::kBrickHeaderBytes) {
        std::uint32_t claimed = sylva::store::detail::get_u32(stored.data() + 4);
        if (claimed % 4 == 0 && claimed >= 4 && claimed <= (4u << 18)) return claimed / 4;
    }
    return stored.empty() ? 1 : 1 + std::to_integer<std::size_t>(stored[0]) % 64;
}

/// decode_brick over any bytes: never reads outside them; an accepted brick matches its
/// recorded checksum; and what it decoded round trips through every codec bit for bit.
inline int fuzz_store_brick(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::store;
    // A copy of exactly `size` bytes, so the address sanitizer sees any read past the end.
    std::vector<std::byte> stored(size);
    if (size > 0) std::memcpy(stored.data(), data, size);
    std::vector<std::uint32_t> words(fuzz_brick_words(stored));
    DecodeStatus st = decode_brick(stored, words);
    SYLVA_FUZZ_CHECK(st == DecodeStatus::ok || st == DecodeStatus::bad_header || st == DecodeStatus::bad_payload ||
                         st == DecodeStatus::bad_checksum,
                     "decode_brick returned an unknown status");
    if (st != DecodeStatus::ok) return 0;
    SYLVA_FUZZ_CHECK(brick_checksum(words) == stored_checksum(stored), "an accepted brick does not match its checksum");
    for (Codec c : {Codec::none, Codec::lz4, Codec::zstd}) {
        std::vector<std::byte> again;
        encode_brick(words, c, 1, again);
        std::vector<std::uint32_t> back(words.size());
        SYLVA_FUZZ_CHECK(decode_brick(again, back) == DecodeStatus::ok, "a re-encoded brick does not decode");
        SYLVA_FUZZ_CHECK(back == words, "a re-encoded brick decodes to other words");
    }
    return 0;
}

/// build_info_from_text over any text: a sylva::Error or a BuildInfo that to_text writes back
/// to text parsing to the same BuildInfo.
inline int fuzz_store_build_info(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::store;
    std::string text(reinterpret_cast<const char*>(data), size);
    BuildInfo info;
    try {
        info = build_info_from_text(text);
    } catch (const sylva::Error&) {
        return 0;
    }
    BuildInfo again;
    try {
        again = build_info_from_text(to_text(info));
    } catch (const sylva::Error& e) {
        std::fprintf(stderr, "to_text output refused: %s\n", e.what());
        SYLVA_FUZZ_CHECK(false, "a parsed build record does not parse again once written");
    }
    // Floats compare by value: NaN != NaN, so compare the texts instead.
    SYLVA_FUZZ_CHECK(to_text(again) == to_text(info), "a build record does not round trip");
    return 0;
}

}  // namespace sylva_fuzz

#endif  // SYLVA_FUZZ_HARNESS_STORE_HPP
