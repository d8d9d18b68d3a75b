// sylva/store/format.hpp -- what a brick store holds, key by key.
//
// A store is an LMDB environment: a directory STORE/ with data.mdb and lock.mdb. It has two
// named databases:
//   "meta", text keys:
//     "magic"        the bytes "sylva-brick-store"
//     "format"       uint32, kFormatVersion when written; a reader refuses a larger one
//                    (1: float32 bricks only, no brick_format line; 2: brick_format added)
//     "build"        BuildInfo as "key=value" lines (what was built, from what, how)
//     "index"        the octree's index words (sylva/octree/brick_source.hpp: layout
//                    sylva/shared/octree_layout.h, brick state SYLVA_OCT_BRICK_HOST, word +12 of
//                    node n = brick key n), written when the build completes
//     "index_xxh3"   uint64 XXH3-64 of the index words
//     "complete"     uint64 brick count; present only once every brick and the index are in
//   "bricks", MDB_INTEGERKEY: key = brick key (native unsigned int, 0 .. brick count - 1),
//     value = the brick as sylva/store/codec.hpp encodes it (header with codec, size and
//     XXH3-64 of the uncompressed words; payload).
// Bricks are committed in batches; a build that stops (kill -9, full disk) leaves every
// committed brick readable, no "complete" key, and `sylva-store build --resume` adds the rest.
#ifndef SYLVA_STORE_FORMAT_HPP
#define SYLVA_STORE_FORMAT_HPP

#include <array>
#include <charconv>
#include <cstdint>
#include <sstream>
#include <string>
#include <string_view>

#include "sylva/core/error.hpp"
#include "sylva/core/math.hpp"
#include "sylva/octree/build.hpp"
#include "sylva/store/codec.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::store {

/// The format this code writes and the newest it reads. Version 2 added the bricks' sample
/// format (BuildInfo::brick_format): a version-1 reader would take unorm16 words for floats, so
/// it must refuse these stores; a version-1 store (no brick_format line) holds float32 bricks.
inline constexpr std::uint32_t kFormatVersion = 2;
/// The "magic" value.
inline constexpr std::string_view kMagic = "sylva-brick-store";

/// What a store was built from and how (the "build" key). Two builds with equal BuildInfo
/// produce equal stores, which is what --resume checks before adding bricks.
struct BuildInfo {
    std::string input;                 ///< the build's INPUT argument (with --resample K when given)
    volume::Dims dims{0};              ///< voxels per axis of the (resampled) volume
    vec3 spacing{1.0f};                ///< world size of one voxel
    std::string voxel_type = "float32";  ///< type of the source voxels (uint8, uint16, float32)
    float range_lo = 0.0f;             ///< raw value mapped to density 0
    float range_hi = 1.0f;             ///< raw value mapped to density 1
    std::string range_source = "procedural densities";  ///< where the range came from
    std::uint32_t brick_size = 32;     ///< B
    std::uint32_t border = 2;          ///< replicated samples per side
    std::uint32_t levels = 0;          ///< octree levels L
    std::uint32_t node_count = 0;      ///< nodes = bricks (every node of the volume octree has one)
    Codec codec = Codec::zstd;
    int level = 1;                     ///< zstd level, -5 .. 19 (negative: zstd's fast modes; 0 for the others)
    /// How the bricks hold samples (octree::BrickFormat; the index's word 5 bits 24-31 say the
    /// same). Absent from version-1 stores, which hold float32.
    octree::BrickFormat brick_format = octree::BrickFormat::Float32;

    /// Words per brick: (B + 2 border)^3 samples in brick_format.
    [[nodiscard]] std::uint32_t brick_words() const {
        return shared::sylva_oct_brick_word_count(brick_size + 2u * border, static_cast<std::uint32_t>(brick_format));
    }
    friend bool operator==(const BuildInfo&, const BuildInfo&) = default;
};

namespace detail {

inline std::string float_text(float f) {
    char buf[32];
    return std::string(buf, std::to_chars(buf, buf + sizeof buf, f).ptr);
}

inline float parse_float(std::string_view s, const char* key) {
    float f = 0.0f;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), f);
    if (ec != std::errc{} || end != s.data() + s.size()) throw Error(std::string("store: build info: bad ") + key);
    return f;
}

inline std::uint32_t parse_u32(std::string_view s, const char* key) {
    std::uint32_t v = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc{} || end != s.data() + s.size()) throw Error(std::string("store: build info: bad ") + key);
    return v;
}

}  // namespace detail

using octree::brick_format_from_name;
using octree::brick_format_name;

/// BuildInfo as "key=value" lines (the "build" key; `sylva-store info` prints them).
inline std::string to_text(const BuildInfo& b) {
    using detail::float_text;
    std::ostringstream o;
    o << "input=" << b.input << "\n"
      << "dims=" << b.dims.x << "x" << b.dims.y << "x" << b.dims.z << "\n"
      << "spacing=" << float_text(b.spacing.x) << "," << float_text(b.spacing.y) << "," << float_text(b.spacing.z) << "\n"
      << "voxel_type=" << b.voxel_type << "\n"
      << "value_range=" << float_text(b.range_lo) << "," << float_text(b.range_hi) << "\n"
      << "value_range_source=" << b.range_source << "\n"
      << "brick=" << b.brick_size << "\n"
      << "border=" << b.border << "\n"
      << "levels=" << b.levels << "\n"
      << "nodes=" << b.node_count << "\n"
      << "codec=" << codec_name(b.codec) << "\n"
      << "level=" << b.level << "\n"
      << "brick_format=" << brick_format_name(b.brick_format) << "\n";
    return o.str();
}

/// Parses to_text's output; throws sylva::Error for a missing or malformed field. brick_format
/// may be absent (version-1 stores: float32).
inline BuildInfo build_info_from_text(std::string_view text) {
    using namespace detail;
    BuildInfo b;
    unsigned seen = 0;
    while (!text.empty()) {
        std::size_t nl = text.find('\n');
        std::string_view line = text.substr(0, nl);
        text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
        std::size_t eq = line.find('=');
        if (eq == std::string_view::npos) continue;
        std::string_view k = line.substr(0, eq), v = line.substr(eq + 1);
        auto triple = [&](char sep, auto parse) {
            std::size_t a = v.find(sep), c = a == std::string_view::npos ? a : v.find(sep, a + 1);
            if (c == std::string_view::npos) throw Error("store: build info: bad " + std::string(k));
            return std::array{parse(v.substr(0, a)), parse(v.substr(a + 1, c - a - 1)), parse(v.substr(c + 1))};
        };
        if (k == "input") b.input = v, seen |= 1;
        else if (k == "dims") {
            auto d = triple('x', [](std::string_view s) { return parse_u32(s, "dims"); });
            b.dims = volume::Dims(d[0], d[1], d[2]), seen |= 2;
        } else if (k == "spacing") {
            auto s = triple(',', [](std::string_view x) { return parse_float(x, "spacing"); });
            b.spacing = vec3(s[0], s[1], s[2]), seen |= 4;
        } else if (k == "voxel_type") b.voxel_type = v, seen |= 8;
        else if (k == "value_range") {
            std::size_t c = v.find(',');
            if (c == std::string_view::npos) throw Error("store: build info: bad value_range");
            b.range_lo = parse_float(v.substr(0, c), "value_range");
            b.range_hi = parse_float(v.substr(c + 1), "value_range");
            seen |= 16;
        } else if (k == "value_range_source") b.range_source = v, seen |= 32;
        else if (k == "brick") b.brick_size = parse_u32(v, "brick"), seen |= 64;
        else if (k == "border") b.border = parse_u32(v, "border"), seen |= 128;
        else if (k == "levels") b.levels = parse_u32(v, "levels"), seen |= 256;
        else if (k == "nodes") b.node_count = parse_u32(v, "nodes"), seen |= 512;
        else if (k == "codec") b.codec = codec_from_name(v), seen |= 1024;
        else if (k == "level") {
            bool negative = !v.empty() && v.front() == '-';
            std::uint32_t magnitude = parse_u32(negative ? v.substr(1) : v, "level");
            // -5 .. 19 is what builds write; larger magnitudes are refused before the sign is
            // applied (fuzz_store_build_info: "level=-2147483648" negated INT_MIN).
            if (magnitude > 19u) throw Error("store: build info: level " + std::string(v) + " is outside -5 .. 19");
            b.level = negative ? -int(magnitude) : int(magnitude);
            seen |= 2048;
        } else if (k == "brick_format") {
            try {
                b.brick_format = brick_format_from_name(v);
            } catch (const Error&) {
                throw Error("store: build info: bad brick_format");
            }
        }
    }
    if (seen != 4095u) throw Error("store: build info lacks fields");
    return b;
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_FORMAT_HPP
