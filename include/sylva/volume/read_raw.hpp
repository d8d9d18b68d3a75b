// sylva/volume/read_raw.hpp -- headerless raw volumes: NAME_XxYxZ_TYPE.raw (the convention of
// ../shared/data and of the Open SciVis datasets), little-endian voxels, x fastest.
//
// The file holds exactly X * Y * Z voxels of TYPE (uint8, uint16 or float32) and nothing else.
// The name carries no spacing: it is (1, 1, 1) unless the caller says otherwise (the lobster of
// ../shared/data, for instance, has spacing (1, 1, 1.4) according to its README).
#ifndef SYLVA_VOLUME_READ_RAW_HPP
#define SYLVA_VOLUME_READ_RAW_HPP

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/value_range.hpp"

namespace sylva::volume {

/// What a raw file holds: its dimensions, voxel type and spacing (world size of one voxel).
struct RawInfo {
    Dims dims{0};
    ScalarType type = ScalarType::U8;
    vec3 spacing{1.0f};
};

namespace detail {

/// "4x5x6" for messages.
inline std::string dims_text(Dims d) {
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z);
}

/// Parses a whole decimal unsigned 32-bit number; false when `s` is anything else.
inline bool parse_u32(std::string_view s, std::uint32_t& out) {
    if (s.empty() || s.front() < '0' || s.front() > '9') return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size();
}

/// The scalar type called `name` ("uint8", "uint16", "float32"); false when unknown.
inline bool scalar_from_name(std::string_view name, ScalarType& out) {
    for (ScalarType t : {ScalarType::U8, ScalarType::U16, ScalarType::F32})
        if (name == scalar_name(t)) {
            out = t;
            return true;
        }
    return false;
}

/// Voxel count of `dims` for `bytes_per_voxel`, with the file named in the error message.
inline std::size_t checked_voxel_count(Dims dims, std::size_t bytes_per_voxel, const std::string& source) {
    try {
        return voxel_count(dims, bytes_per_voxel);
    } catch (const Error& e) {
        throw Error(source + ": " + e.what());
    }
}

/// Reverses the byte order of every `width`-byte word in `bytes` (big <-> little endian).
inline void swap_bytes(std::vector<std::byte>& bytes, std::size_t width) {
    if (width <= 1) return;
    for (std::size_t i = 0; i + width <= bytes.size(); i += width)
        for (std::size_t a = i, b = i + width - 1; a < b; ++a, --b) std::swap(bytes[a], bytes[b]);
}

/// Spacing check shared by the readers: each component finite and > 0.
inline void check_spacing(vec3 s, const std::string& source) {
    if (!all_finite(s) || !(s.x > 0.0f) || !(s.y > 0.0f) || !(s.z > 0.0f))
        throw Error(source + ": spacing (" + std::to_string(s.x) + ", " + std::to_string(s.y) + ", " +
                    std::to_string(s.z) + ") must be finite and positive");
}

}  // namespace detail

/// Parses a file name following NAME_XxYxZ_TYPE.raw (any folder before it), e.g.
/// "lobster_301x324x56_uint8.raw" -> dims (301, 324, 56), uint8, spacing (1, 1, 1). TYPE is
/// uint8, uint16 or float32. Throws sylva::Error naming the file and what is wrong otherwise.
/// Zero or overflowing dimensions parse; read_raw rejects them.
inline RawInfo parse_raw_name(std::string_view filename) {
    std::string name = std::filesystem::path(filename).filename().string();
    auto fail = [&](const std::string& why) -> Error {
        return Error("raw volume name '" + name + "' does not follow NAME_XxYxZ_TYPE.raw: " + why);
    };
    std::string ext = std::filesystem::path(name).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".raw" || name.size() <= ext.size()) throw fail("it does not end in .raw");
    std::string_view stem(name.data(), name.size() - ext.size());
    std::size_t type_at = stem.rfind('_');
    if (type_at == std::string_view::npos) throw fail("no _TYPE before .raw");
    // NAME_ is optional: "4x4x4_uint8.raw" names its dimensions and type too.
    std::size_t dims_at = type_at == 0 ? std::string_view::npos : stem.rfind('_', type_at - 1);
    dims_at = dims_at == std::string_view::npos ? 0 : dims_at + 1;
    RawInfo info;
    std::string_view type = stem.substr(type_at + 1);
    if (!detail::scalar_from_name(type, info.type))
        throw fail("unknown voxel type '" + std::string(type) + "' (known: uint8, uint16, float32)");
    std::string_view dims = stem.substr(dims_at, type_at - dims_at);
    std::size_t x1 = dims.find('x'), x2 = x1 == std::string_view::npos ? x1 : dims.find('x', x1 + 1);
    if (x2 == std::string_view::npos || !detail::parse_u32(dims.substr(0, x1), info.dims.x) ||
        !detail::parse_u32(dims.substr(x1 + 1, x2 - x1 - 1), info.dims.y) ||
        !detail::parse_u32(dims.substr(x2 + 1), info.dims.z))
        throw fail("dimensions '" + std::string(dims) + "' are not three decimal numbers below 2^32 joined by 'x'");
    return info;
}

/// Reads a headerless little-endian raw volume, x fastest, with the dimensions, type and spacing
/// of `info`. The value range is chosen by `range` (default: the data's min and max; see
/// sylva/volume/value_range.hpp). Throws sylva::Error naming the file when it is missing or
/// unreadable, when its size differs from dims * bytes per voxel (bigger or truncated: both byte
/// counts are in the message), when a dimension is zero or their product overflows, when the
/// spacing is not finite and positive, or when a float32 voxel is NaN or infinite (with its index).
inline Volume read_raw(const std::filesystem::path& path, const RawInfo& info, const ValueRange& range = {}) {
    const std::string source = "raw volume " + path.string();
    if (info.type != ScalarType::U8 && info.type != ScalarType::U16 && info.type != ScalarType::F32)
        throw Error(source + ": unknown voxel type " + std::to_string(int(info.type)));
    const std::size_t width = scalar_bytes(info.type);
    const std::size_t n = detail::checked_voxel_count(info.dims, width, source);
    detail::check_spacing(info.spacing, source);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw Error(source + ": no such file" + (ec ? " (" + ec.message() + ")" : std::string()));
    const std::uintmax_t actual = std::filesystem::file_size(path, ec);
    if (ec) throw Error(source + ": cannot read its size: " + ec.message());
    const std::uintmax_t expected = std::uintmax_t{n} * width;
    if (actual != expected)
        throw Error(source + ": " + std::to_string(actual) + " bytes, but " + detail::dims_text(info.dims) + " " +
                    scalar_name(info.type) + " voxels need " + std::to_string(expected) + " bytes (" +
                    (actual < expected ? "truncated" : "too big") + ")");
    Volume v;
    v.type = info.type;
    v.dims = info.dims;
    v.spacing = info.spacing;
    v.bytes.resize(n * width);
    std::ifstream in(path, std::ios::binary);
    if (!in || !in.read(reinterpret_cast<char*>(v.bytes.data()), static_cast<std::streamsize>(v.bytes.size())))
        throw Error(source + ": cannot read " + std::to_string(expected) + " bytes");
    apply_value_range(v, range, source);
    return v;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_READ_RAW_HPP
