// sylva/volume/value_range.hpp -- which raw voxel values map to normalised density 0 and 1.
//
// Every classifier, builder, transfer function, iso value and LoD statistic reads normalised
// density d = clamp((v - lo) / (hi - lo), 0, 1) (sylva/volume/grid.hpp). The value range
// [lo, hi] is chosen here, by one of three modes:
//  * Auto (the default): the volume's stated range when its file has one (NRRD `min:` and
//    `max:`; one stated alone takes the other end from the data), else the data's own min
//    and max. This is what VTK, ParaView and 3D Slicer map a transfer function over by
//    default, and the only choice that shows a 12-bit CT scan stored in uint16 (values
//    0..4095 of 0..65535) with the default threshold and presets.
//  * Type: the scalar type's full range, 0..255 for uint8 and 0..65535 for uint16 (sylva's
//    behaviour before value ranges existed). float32 has no such range: the data's min and max.
//  * Explicit: [LO, HI] as given (finite, LO < HI). Values outside it clamp to 0 or 1.
// A data range that is one value v (a constant volume) cannot be divided by: Auto widens it to
// include 0, [min(v, 0), max(v, 0)], so a constant non-zero volume is fully dense and a zero
// one empty ([0, 1]).
#ifndef SYLVA_VOLUME_VALUE_RANGE_HPP
#define SYLVA_VOLUME_VALUE_RANGE_HPP

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

/// How a volume's raw values map to normalised density (see the top of this header).
struct ValueRange {
    enum class Mode : std::uint8_t {
        Auto,      ///< the file's stated range, else the data's min/max (default)
        Type,      ///< the scalar type's full range (uint8 0..255, uint16 0..65535; float32: data)
        Explicit,  ///< [lo, hi] as given
    };
    Mode mode = Mode::Auto;
    float lo = 0.0f;  ///< Explicit only: the raw value that maps to density 0
    float hi = 1.0f;  ///< Explicit only: the raw value that maps to density 1

    /// Auto mode (the default).
    static ValueRange automatic() { return {}; }
    /// Type mode.
    static ValueRange of_type() { return {Mode::Type, 0.0f, 1.0f}; }
    /// Explicit [lo, hi]; throws sylva::Error unless both are finite and lo < hi.
    static ValueRange between(float lo, float hi) {
        if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
            throw Error("value range: need finite LO < HI, got " + std::to_string(lo) + " and " + std::to_string(hi));
        return {Mode::Explicit, lo, hi};
    }

    /// Parses "auto", "type" or "LO,HI" (two decimal numbers, e.g. "-1000,3000" or "0,4095").
    /// Throws sylva::Error naming the text otherwise.
    static ValueRange parse(std::string_view text);

    /// The text parse() reads back to the same range: "auto", "type" or "LO,HI" (shortest
    /// round-trip decimals).
    [[nodiscard]] std::string text() const {
        if (mode == Mode::Auto) return "auto";
        if (mode == Mode::Type) return "type";
        char buf[64];
        auto end = std::to_chars(buf, buf + 31, lo).ptr;
        *end++ = ',';
        end = std::to_chars(end, buf + sizeof buf, hi).ptr;
        return std::string(buf, end);
    }
};

/// "data min/max", "file min/max", "type range", "explicit", "constant data, widened to 0".
inline const char* range_source_name(RangeSource s) {
    switch (s) {
        case RangeSource::Data: return "data min/max";
        case RangeSource::Stated: return "file min/max";
        case RangeSource::Type: return "type range";
        case RangeSource::Explicit: return "explicit";
        default: return "constant data, widened to 0";
    }
}

/// The smallest and largest value of a volume's voxels. Throws sylva::Error starting with
/// `what` and naming the voxel when a float32 voxel is NaN or infinite, and for an empty volume.
inline std::pair<float, float> data_min_max(const Volume& v, const std::string& what = "volume");

/// The range `r` selects for `v` and where it came from (nothing is changed). Throws
/// sylva::Error starting with `what` for a NaN/inf float32 voxel, when a stated range is
/// not finite with lo < hi, and when the chosen range is too wide for float32 (hi - lo overflows).
inline std::pair<std::pair<float, float>, RangeSource> choose_range(const Volume& v, const ValueRange& r,
                                                                    const std::string& what = "volume");

/// Sets v.range_lo, v.range_hi and v.range_source as `r` says (see choose_range).
inline void apply_value_range(Volume& v, const ValueRange& r, const std::string& what = "volume") {
    auto [range, source] = choose_range(v, r, what);
    v.range_lo = range.first;
    v.range_hi = range.second;
    v.range_source = source;
}

// ---- implementation ----------------------------------------------------------------------

namespace detail::range {

inline bool parse_float(std::string_view s, float& out) {
    while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
    while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
    if (s.empty()) return false;
    if (s.front() == '+') s.remove_prefix(1);
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size() && std::isfinite(out);
}

template <class T>
std::pair<float, float> typed_min_max(const Volume& v, const std::string& what) {
    const std::size_t n = v.voxels();
    T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
    for (std::size_t i = 0; i < n; ++i) {
        T x;
        std::memcpy(&x, &v.bytes[i * sizeof(T)], sizeof(T));
        if constexpr (std::is_floating_point_v<T>) {
            if (!std::isfinite(x))
                throw Error(what + ": float32 voxel " + std::to_string(i) + " is " + (std::isnan(x) ? "NaN" : "infinite"));
        }
        lo = std::min(lo, x);
        hi = std::max(hi, x);
    }
    return {static_cast<float>(lo), static_cast<float>(hi)};
}

}  // namespace detail::range

inline ValueRange ValueRange::parse(std::string_view text) {
    if (text == "auto") return automatic();
    if (text == "type") return of_type();
    std::size_t comma = text.find(',');
    float lo = 0.0f, hi = 0.0f;
    if (comma == std::string_view::npos || !detail::range::parse_float(text.substr(0, comma), lo) ||
        !detail::range::parse_float(text.substr(comma + 1), hi))
        throw Error("value range '" + std::string(text) + "' is not auto, type or LO,HI (two finite numbers)");
    if (!(lo < hi)) throw Error("value range '" + std::string(text) + "': LO must be below HI");
    return between(lo, hi);
}

inline std::pair<float, float> data_min_max(const Volume& v, const std::string& what) {
    if (v.voxels() == 0) throw Error(what + ": no voxels, so no value range");
    if (v.bytes.size() != v.voxels() * scalar_bytes(v.type))
        throw Error(what + ": " + std::to_string(v.bytes.size()) + " bytes are not whole " + scalar_name(v.type) + " voxels");
    switch (v.type) {
        case ScalarType::U8: return detail::range::typed_min_max<std::uint8_t>(v, what);
        case ScalarType::U16: return detail::range::typed_min_max<std::uint16_t>(v, what);
        default: return detail::range::typed_min_max<float>(v, what);
    }
}

namespace detail::range {
/// Throws unless hi - lo is a finite float32: densities are (v - lo) / (hi - lo) on the host and
/// the GPU alike, so a finite range wider than FLT_MAX (voxels near -3.4e38 and +3.4e38) has no
/// density for anything (it used to surface later as a NaN density).
inline std::pair<std::pair<float, float>, RangeSource> fits(std::pair<float, float> p, RangeSource source,
                                                           const std::string& what) {
    if (!std::isfinite(p.second - p.first))
        throw Error(what + ": the value range [" + std::to_string(p.first) + ", " + std::to_string(p.second) +
                    "] is too wide for float32 (max - min overflows); give a narrower range explicitly (LO,HI)");
    return {p, source};
}
}  // namespace detail::range

inline std::pair<std::pair<float, float>, RangeSource> choose_range(const Volume& v, const ValueRange& r,
                                                                    const std::string& what) {
    using P = std::pair<float, float>;
    using detail::range::fits;
    if (r.mode == ValueRange::Mode::Explicit) {
        if (!std::isfinite(r.lo) || !std::isfinite(r.hi) || !(r.lo < r.hi))
            throw Error(what + ": explicit value range [" + std::to_string(r.lo) + ", " + std::to_string(r.hi) +
                        "] is not finite with LO < HI");
        return fits(P{r.lo, r.hi}, RangeSource::Explicit, what);
    }
    if (r.mode == ValueRange::Mode::Type && v.type == ScalarType::U8) return {P{0.0f, 255.0f}, RangeSource::Type};
    if (r.mode == ValueRange::Mode::Type && v.type == ScalarType::U16) return {P{0.0f, 65535.0f}, RangeSource::Type};
    P data = data_min_max(v, what);  // also rejects NaN and infinity in float32 volumes
    if (r.mode == ValueRange::Mode::Auto && v.stated_range) {
        P s = *v.stated_range;  // a NaN end is not stated: the data's
        if (std::isnan(s.first)) s.first = data.first;
        if (std::isnan(s.second)) s.second = data.second;
        if (!std::isfinite(s.first) || !std::isfinite(s.second) || !(s.first < s.second))
            throw Error(what + ": stated value range [" + std::to_string(s.first) + ", " + std::to_string(s.second) +
                        "] is not finite with min < max");
        return fits(s, RangeSource::Stated, what);
    }
    if (data.first < data.second) return fits(data, RangeSource::Data, what);
    float c = data.first;
    if (c == 0.0f) return {P{0.0f, 1.0f}, RangeSource::Constant};
    return {P{std::min(c, 0.0f), std::max(c, 0.0f)}, RangeSource::Constant};
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_VALUE_RANGE_HPP
