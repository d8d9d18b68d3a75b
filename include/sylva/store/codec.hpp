// sylva/store/codec.hpp -- how one brick is stored in the brick store (sylva/store/store.hpp):
// compressed, with a checksum over its uncompressed words.
//
// A stored brick is a 16-byte header followed by the payload:
//   byte 0      codec (Codec: 0 none, 1 lz4, 2 zstd)
//   byte 1      filter (0 none; 1 byte shuffle: the payload compresses the brick's bytes
//               reordered plane by plane -- all bytes 0 of the 32-bit words, then all bytes 1,
//               2, 3 -- which groups the slowly varying exponent bytes of float32 samples (and
//               the high bytes of the two unorm16 samples a word); decoding undoes it, so the
//               words come back exactly)
//   bytes 2-3   reserved, 0
//   bytes 4-7   the brick's uncompressed size in bytes (little-endian uint32): 4 * words
//   bytes 8-15  XXH3-64 of the uncompressed brick words as the host holds them (little-endian
//               uint64), checked after every decode
//   bytes 16-   payload
// Gobbetti et al. (section 6) compress bricks losslessly with LZO; lz4 is LZO's modern
// successor and zstd trades speed for size (measurements: the store's proposal in the README).
#ifndef SYLVA_STORE_CODEC_HPP
#define SYLVA_STORE_CODEC_HPP

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <lz4.h>
#include <xxhash.h>
#include <zstd.h>

#include "sylva/core/error.hpp"

namespace sylva::store {

/// Compression of the stored bricks.
enum class Codec : std::uint8_t {
    none = 0,  ///< raw words (the shuffle filter is not applied)
    lz4 = 1,   ///< LZ4 (fast; Gobbetti et al. used LZO, of the same family)
    zstd = 2,  ///< Zstandard at Settings::level (default 1)
};

/// "none", "lz4", "zstd".
inline const char* codec_name(Codec c) { return c == Codec::none ? "none" : (c == Codec::lz4 ? "lz4" : "zstd"); }

/// The codec called `name`; throws sylva::Error listing the known ones.
inline Codec codec_from_name(std::string_view name) {
    for (Codec c : {Codec::none, Codec::lz4, Codec::zstd})
        if (name == codec_name(c)) return c;
    throw Error("unknown codec '" + std::string(name) + "' (known: none, lz4, zstd)");
}

/// Bytes of a stored brick's header.
inline constexpr std::size_t kBrickHeaderBytes = 16;

/// Checksum of brick words (XXH3-64 over their bytes).
inline std::uint64_t brick_checksum(std::span<const std::uint32_t> words) {
    return XXH3_64bits(words.data(), words.size_bytes());
}

namespace detail {

inline void put_u32(std::byte* p, std::uint32_t v) { std::memcpy(p, &v, 4); }
inline void put_u64(std::byte* p, std::uint64_t v) { std::memcpy(p, &v, 8); }
inline std::uint32_t get_u32(const std::byte* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
}
inline std::uint64_t get_u64(const std::byte* p) {
    std::uint64_t v;
    std::memcpy(&v, p, 8);
    return v;
}

/// Byte plane k of word i goes to out[k * n + i].
inline void shuffle4(std::span<const std::uint32_t> words, std::byte* out) {
    const std::size_t n = words.size();
    const auto* in = reinterpret_cast<const std::byte*>(words.data());
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < 4; ++k) out[k * n + i] = in[4 * i + k];
}

/// The inverse of shuffle4.
inline void unshuffle4(const std::byte* in, std::span<std::uint32_t> words) {
    const std::size_t n = words.size();
    auto* out = reinterpret_cast<std::byte*>(words.data());
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < 4; ++k) out[4 * i + k] = in[k * n + i];
}

/// One zstd compression and one decompression context per thread, kept: creating them per
/// brick allocates (and page-faults) their workspaces every time.
struct ZstdContexts {
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_DCtx* d = ZSTD_createDCtx();
    ZstdContexts() = default;
    ZstdContexts(const ZstdContexts&) = delete;
    ZstdContexts& operator=(const ZstdContexts&) = delete;
    ~ZstdContexts() {
        ZSTD_freeCCtx(c);
        ZSTD_freeDCtx(d);
    }
};
inline ZstdContexts& zstd_contexts() {
    thread_local ZstdContexts ctx;
    if (!ctx.c || !ctx.d) throw Error("store: cannot create a zstd context");
    return ctx;
}

}  // namespace detail

/// Encodes one brick (header + payload) into `out` (resized). `level` is zstd's level (1-19);
/// lz4 and none ignore it. Throws sylva::Error when the compressor fails.
inline void encode_brick(std::span<const std::uint32_t> words, Codec codec, int level, std::vector<std::byte>& out) {
    const std::size_t raw = words.size_bytes();
    if (raw > 0x7FFFFFFFu) throw Error("store: a brick of " + std::to_string(raw) + " bytes is too large");
    thread_local std::vector<std::byte> shuffled;  // reused: no page faults per brick
    const void* src = words.data();
    if (codec != Codec::none) {
        shuffled.resize(raw);
        detail::shuffle4(words, shuffled.data());
        src = shuffled.data();
    }
    std::size_t bound = codec == Codec::zstd  ? ZSTD_compressBound(raw)
                        : codec == Codec::lz4 ? std::size_t(LZ4_compressBound(int(raw)))
                                              : raw;
    // Compress into a reused buffer, then copy out only the bytes made: `out` is neither
    // zero-filled to the bound nor left holding it as capacity.
    thread_local std::vector<std::byte> scratch;
    if (scratch.size() < kBrickHeaderBytes + bound) scratch.resize(kBrickHeaderBytes + bound);
    std::byte* payload = scratch.data() + kBrickHeaderBytes;
    std::size_t size = raw;
    if (codec == Codec::zstd) {
        size = ZSTD_compressCCtx(detail::zstd_contexts().c, payload, bound, src, raw, level);
        if (ZSTD_isError(size)) throw Error(std::string("store: zstd compression failed: ") + ZSTD_getErrorName(size));
    } else if (codec == Codec::lz4) {
        int n = LZ4_compress_default(static_cast<const char*>(src), reinterpret_cast<char*>(payload), int(raw), int(bound));
        if (n <= 0) throw Error("store: lz4 compression failed");
        size = std::size_t(n);
    } else {
        std::memcpy(payload, src, raw);
    }
    out.assign(scratch.begin(), scratch.begin() + std::ptrdiff_t(kBrickHeaderBytes + size));
    out[0] = std::byte(codec);
    out[1] = std::byte(codec == Codec::none ? 0 : 1);
    out[2] = out[3] = std::byte(0);
    detail::put_u32(out.data() + 4, std::uint32_t(raw));
    detail::put_u64(out.data() + 8, brick_checksum(words));
}

/// What decoding a stored brick gave.
enum class DecodeStatus : std::uint8_t {
    ok,          ///< `words` holds the brick and its checksum matched
    bad_header,  ///< too short, unknown codec or filter, reserved bits set, or a size other than `words`'
    bad_payload, ///< the decompressor failed or produced the wrong number of bytes (truncation)
    bad_checksum ///< decoded, but the words do not match the stored checksum
};

/// Decodes a stored brick into `words` (its size must be the brick's). Never reads outside
/// `stored`, whatever it holds.
inline DecodeStatus decode_brick(std::span<const std::byte> stored, std::span<std::uint32_t> words) {
    if (stored.size() < kBrickHeaderBytes) return DecodeStatus::bad_header;
    const auto codec = std::to_integer<std::uint8_t>(stored[0]);
    const auto filter = std::to_integer<std::uint8_t>(stored[1]);
    const std::size_t raw = words.size_bytes();
    if (codec > 2 || filter > 1 || (codec == 0) != (filter == 0) || stored[2] != std::byte(0) ||
        stored[3] != std::byte(0) || detail::get_u32(stored.data() + 4) != raw)
        return DecodeStatus::bad_header;
    const std::byte* payload = stored.data() + kBrickHeaderBytes;
    const std::size_t size = stored.size() - kBrickHeaderBytes;
    thread_local std::vector<std::byte> scratch;
    std::byte* dst = reinterpret_cast<std::byte*>(words.data());
    if (filter == 1) {
        scratch.resize(raw);
        dst = scratch.data();
    }
    if (codec == 2) {
        std::size_t n = ZSTD_decompressDCtx(detail::zstd_contexts().d, dst, raw, payload, size);
        if (ZSTD_isError(n) || n != raw) return DecodeStatus::bad_payload;
    } else if (codec == 1) {
        int n = LZ4_decompress_safe(reinterpret_cast<const char*>(payload), reinterpret_cast<char*>(dst), int(size),
                                    int(raw));
        if (n < 0 || std::size_t(n) != raw) return DecodeStatus::bad_payload;
    } else {
        if (size != raw) return DecodeStatus::bad_payload;
        std::memcpy(dst, payload, raw);
    }
    if (filter == 1) detail::unshuffle4(scratch.data(), words);
    if (brick_checksum(words) != detail::get_u64(stored.data() + 8)) return DecodeStatus::bad_checksum;
    return DecodeStatus::ok;
}

/// The checksum a stored brick's header records (0 when the header is too short).
inline std::uint64_t stored_checksum(std::span<const std::byte> stored) {
    return stored.size() < kBrickHeaderBytes ? 0u : detail::get_u64(stored.data() + 8);
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_CODEC_HPP
