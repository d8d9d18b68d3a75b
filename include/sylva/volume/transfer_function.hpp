// sylva/volume/transfer_function.hpp -- 1-D transfer functions: normalised density -> RGBA.
//
// Semantics (shared by the host renderers and the shaders):
//  * Colours are straight (not premultiplied) RGBA, every component in [0, 1]. Alpha is the
//    opacity of a unit-length sample; integrators apply their own opacity correction.
//  * A transfer function is defined by control points (density, rgba), sorted by density and
//    joined piecewise linearly; below the first point it is the first point's RGBA, above the
//    last the last's (clamped). Two points at the same density make a step (the later one wins
//    at that density).
//  * It is sampled into N >= 256 table entries (Kinkelin section 6.2: a 256-texel RGBA8 table);
//    entry i holds the control-point curve at density i / (N - 1).
//  * Lookups interpolate linearly between entries, exactly as the shaders do:
//        x = clamp(d, 0, 1) * (N - 1),  i = min(floor(x), N - 2),  f = x - i,
//        at(d) = entry[i] + (entry[i + 1] - entry[i]) * f      (NaN d reads as 0)
//  * On the GPU the table is one 32-bit word per entry (packed_rgba8): R in bits 0-7, G in
//    bits 8-15, B in bits 16-23, A in bits 24-31, each round(c * 255). GLSL's unpackUnorm4x8
//    returns exactly (R, G, B, A) / 255 from such a word.
//
// File formats:
//  * text: one control point per line, "density r g b a" (five numbers separated by spaces or
//    tabs); '#' starts a comment that runs to the end of the line; blank lines are skipped.
//  * JSON: {"points": [[d, r, g, b, a], ...], "entries": 256}; "entries" is optional (256),
//    other keys are ignored. Parsed with nlohmann-json (Debian's nlohmann-json3-dev, found with
//    __has_include: a well-kept parser whose errors give line and column, rather than a
//    hand-written one); without it from_json throws an error that says so.
#ifndef SYLVA_VOLUME_TRANSFER_FUNCTION_HPP
#define SYLVA_VOLUME_TRANSFER_FUNCTION_HPP

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <string_view>
#include <cctype>
#include <vector>

#if __has_include(<nlohmann/json.hpp>)
#include <nlohmann/json.hpp>
#define SYLVA_TF_HAS_JSON 1
#else
#define SYLVA_TF_HAS_JSON 0
#endif

#include "sylva/core/error.hpp"
#include "sylva/core/math.hpp"

namespace sylva::volume {

/// One control point of a transfer function: straight RGBA (each in [0, 1]) at a normalised density.
struct ControlPoint {
    float density = 0.0f;
    vec4 rgba{0.0f};
};

namespace detail::tf {

/// Throws `where: why` when a control point has a non-finite density or a component outside [0, 1].
inline void check_point(const ControlPoint& p, const std::string& where) {
    if (!std::isfinite(p.density)) throw Error(where + ": density is not a finite number");
    for (int c = 0; c < 4; ++c)
        if (!(p.rgba[c] >= 0.0f && p.rgba[c] <= 1.0f))
            throw Error(where + ": " + "rgba"[c] + std::string(" = ") + std::to_string(p.rgba[c]) +
                        " is not in [0, 1]");
}

/// The piecewise-linear control-point curve at density `d` (points sorted by density).
inline vec4 curve_at(const std::vector<ControlPoint>& points, float d) {
    if (d <= points.front().density) return points.front().rgba;
    if (d >= points.back().density) return points.back().rgba;
    auto next =
        std::upper_bound(points.begin(), points.end(), d, [](float x, const ControlPoint& p) { return x < p.density; });
    const ControlPoint& a = *(next - 1);
    const ControlPoint& b = *next;
    float f = (d - a.density) / (b.density - a.density);
    return a.rgba * (1.0f - f) + b.rgba * f;
}

/// One 0..255 channel of a component in [0, 1].
inline std::uint32_t unorm8(float c) {
    return static_cast<std::uint32_t>(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f));
}

/// A file's whole text, or an error naming it.
inline std::string read_text(const std::filesystem::path& path, const std::string& what) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(what + " " + path.string() + ": cannot open it (missing or unreadable)");
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Parses a whole number (decimal, exponent allowed, locale independent); false otherwise.
inline bool parse_float(std::string_view s, double& out) {
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    if (s.empty()) return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size() && std::isfinite(out);
}

/// "'TOKEN' is outside the float32 range" when a parsed finite double does not fit a float
/// (1e308 would become inf); empty when it fits (values below FLT_MIN round towards 0).
inline std::string float32_problem(double v, std::string_view token) {
    if (std::fabs(v) <= double(std::numeric_limits<float>::max())) return {};
    std::string why(1, '\'');
    why.append(token.substr(0, 40)).append("' is outside the float32 range");
    return why;
}

}  // namespace detail::tf

/// A 1-D transfer function: N RGBA entries sampled from piecewise-linear control points (see
/// the semantics at the top of this header).
class TransferFunction {
public:
    /// Kinkelin section 6.2: "a 1D RGBA texture, 256 texels wide and using 8 bits per component".
    static constexpr std::size_t default_entries = 256;
    static constexpr std::size_t min_entries = 256;
    static constexpr std::size_t max_entries = std::size_t{1} << 16;

    /// A grey ramp: transparent black at density 0 to opaque white at 1.
    TransferFunction() : TransferFunction({{0.0f, vec4(0.0f)}, {1.0f, vec4(1.0f)}}) {}

    /// Samples `points` (any order; sorted by density here) into `entries` entries. Throws
    /// sylva::Error when there are no points, a density is not finite, a component is outside
    /// [0, 1] (naming the point), or `entries` is outside [256, 65536].
    explicit TransferFunction(std::vector<ControlPoint> points, std::size_t entries = default_entries)
        : points_(std::move(points)) {
        if (entries < min_entries || entries > max_entries)
            throw Error("transfer function: " + std::to_string(entries) + " entries (need 256 to 65536)");
        if (points_.empty()) throw Error("transfer function: no control points");
        for (std::size_t i = 0; i < points_.size(); ++i)
            detail::tf::check_point(points_[i], "transfer function: control point " + std::to_string(i));
        std::stable_sort(points_.begin(), points_.end(),
                         [](const ControlPoint& a, const ControlPoint& b) { return a.density < b.density; });
        entries_.resize(entries);
        for (std::size_t i = 0; i < entries; ++i)
            entries_[i] = detail::tf::curve_at(points_, static_cast<float>(i) / static_cast<float>(entries - 1));
    }

    /// Linear interpolation between the entries around density `d` (the shader's rule, above).
    [[nodiscard]] vec4 at(float d) const {
        float n1 = static_cast<float>(entries_.size() - 1);
        float x = (d > 0.0f ? std::min(d, 1.0f) : 0.0f) * n1;
        std::size_t i = std::min(static_cast<std::size_t>(x), entries_.size() - 2);
        float f = x - static_cast<float>(i);
        return entries_[i] + (entries_[i + 1] - entries_[i]) * f;
    }

    /// Number of table entries N.
    [[nodiscard]] std::size_t size() const { return entries_.size(); }
    /// The table: entry i is the control-point curve at density i / (N - 1).
    [[nodiscard]] const std::vector<vec4>& entries() const { return entries_; }
    /// The control points, sorted by density.
    [[nodiscard]] const std::vector<ControlPoint>& points() const { return points_; }

    /// The GPU table: one word per entry, R bits 0-7, G bits 8-15, B bits 16-23, A bits 24-31,
    /// each channel round(c * 255) (GLSL: unpackUnorm4x8).
    [[nodiscard]] std::vector<std::uint32_t> packed_rgba8() const {
        std::vector<std::uint32_t> words(entries_.size());
        for (std::size_t i = 0; i < entries_.size(); ++i) words[i] = pack_rgba8(entries_[i]);
        return words;
    }
    /// One packed word (layout of packed_rgba8).
    [[nodiscard]] static std::uint32_t pack_rgba8(vec4 c) {
        using detail::tf::unorm8;
        return unorm8(c.r) | (unorm8(c.g) << 8) | (unorm8(c.b) << 16) | (unorm8(c.a) << 24);
    }
    /// Inverse of pack_rgba8: (R, G, B, A) / 255.
    [[nodiscard]] static vec4 unpack_rgba8(std::uint32_t w) {
        return vec4(float(w & 0xFFu), float((w >> 8) & 0xFFu), float((w >> 16) & 0xFFu), float(w >> 24)) / 255.0f;
    }

    /// The largest alpha of any entry.
    [[nodiscard]] float max_alpha() const {
        float a = 0.0f;
        for (const vec4& e : entries_) a = std::max(a, e.a);
        return a;
    }
    /// True when some density is not fully transparent (some entry has alpha > 0), i.e. a volume
    /// rendered with this function can show anything at all.
    [[nodiscard]] bool any_opaque() const { return max_alpha() > 0.0f; }

    /// Transparent below `lo`, rising linearly in alpha to `rgba` at `hi`, `rgba` above (the
    /// colour is rgba's throughout). Throws unless lo < hi, both finite, rgba in [0, 1].
    [[nodiscard]] static TransferFunction ramp(float lo, float hi, vec4 rgba, std::size_t entries = default_entries) {
        if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
            throw Error("transfer function ramp: need finite lo < hi, got " + std::to_string(lo) + " and " +
                        std::to_string(hi));
        return TransferFunction({{lo, vec4(vec3(rgba), 0.0f)}, {hi, rgba}}, entries);
    }

    /// A CT preset for normalised 8-bit CT data (engine, lobster, bonsai): transparent below
    /// 0.1 (the noise threshold of Kinkelin section 6.1), faint reddish soft tissue from 0.1 to
    /// 0.4, then a steep rise to nearly opaque bone white from 0.45 up.
    [[nodiscard]] static TransferFunction ct_bone_tissue(std::size_t entries = default_entries) {
        return TransferFunction({{0.00f, {0.00f, 0.00f, 0.00f, 0.00f}},
                                 {0.10f, {0.60f, 0.25f, 0.15f, 0.00f}},
                                 {0.25f, {0.85f, 0.45f, 0.30f, 0.04f}},
                                 {0.40f, {0.90f, 0.70f, 0.55f, 0.08f}},
                                 {0.55f, {0.95f, 0.92f, 0.85f, 0.70f}},
                                 {1.00f, {1.00f, 1.00f, 1.00f, 0.95f}}},
                                entries);
    }

    /// Reads a transfer-function file: JSON when its extension is .json in any letter case
    /// (tf.JSON too), the text format otherwise. Throws as from_json / from_text do.
    [[nodiscard]] static TransferFunction from_file(const std::filesystem::path& path);
    /// Reads control points from a text file (format at the top of this header). Throws
    /// sylva::Error naming the file and line for a malformed line or a value outside [0, 1], and
    /// when the file is missing or has no points.
    [[nodiscard]] static TransferFunction from_text(const std::filesystem::path& path,
                                                    std::size_t entries = default_entries);
    /// Reads {"points": [[d, r, g, b, a], ...], "entries": N} (format at the top of this header).
    /// Throws sylva::Error naming the file (and, for malformed JSON, the line and column), for a
    /// wrong point (naming it), a bad "entries", a missing "points", or a missing file.
    [[nodiscard]] static TransferFunction from_json(const std::filesystem::path& path);

private:
    std::vector<ControlPoint> points_;
    std::vector<vec4> entries_;
};

namespace detail::tf {

/// The control point on one text line (comment already stripped), or an error naming the line.
inline ControlPoint text_point(const std::string& line, const std::string& where) {
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string s; words >> s;) w.push_back(s);
    if (w.size() != 5)
        throw Error(where + ": expected 'density r g b a' (5 numbers), found " + std::to_string(w.size()) + " values");
    double v[5];
    for (int i = 0; i < 5; ++i)
        if (!parse_float(w[i], v[i])) throw Error(where + ": '" + w[i] + "' is not a finite number");
        else if (std::string why = float32_problem(v[i], w[i]); !why.empty()) throw Error(where + ": " + why);
    ControlPoint p{static_cast<float>(v[0]), vec4(float(v[1]), float(v[2]), float(v[3]), float(v[4]))};
    check_point(p, where);
    return p;
}

}  // namespace detail::tf

inline TransferFunction TransferFunction::from_file(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".json" ? from_json(path) : from_text(path);
}

inline TransferFunction TransferFunction::from_text(const std::filesystem::path& path, std::size_t entries) {
    const std::string source = "transfer function file " + path.string();
    std::istringstream in(detail::tf::read_text(path, "transfer function file"));
    std::vector<ControlPoint> points;
    std::string line;
    for (int line_no = 1; std::getline(in, line); ++line_no) {
        line = line.substr(0, line.find('#'));
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        points.push_back(detail::tf::text_point(line, source + " line " + std::to_string(line_no)));
    }
    if (points.empty()) throw Error(source + ": no control points");
    return TransferFunction(std::move(points), entries);
}

#if SYLVA_TF_HAS_JSON
namespace detail::tf {

using Json = nlohmann::json;

/// Point i of "points" as a ControlPoint: an array of exactly 5 numbers, each within float32.
inline ControlPoint json_point(const Json& p, std::size_t i, const std::string& source) {
    const std::string where = source + ": point " + std::to_string(i);
    if (!p.is_array()) throw Error(where + " is " + std::string(p.type_name()) + ", not an array [d, r, g, b, a]");
    if (p.size() != 5)
        throw Error(where + " has " + std::to_string(p.size()) + " numbers; a point is exactly 5 numbers [d, r, g, b, a]");
    double v[5];
    for (std::size_t k = 0; k < 5; ++k) {
        if (!p[k].is_number()) throw Error(where + ": value " + std::to_string(k) + " is " + p[k].type_name() + ", not a number");
        v[k] = p[k].get<double>();
        if (std::string why = float32_problem(v[k], p[k].dump()); !why.empty()) throw Error(where + ": " + why);
    }
    ControlPoint cp{float(v[0]), vec4(float(v[1]), float(v[2]), float(v[3]), float(v[4]))};
    check_point(cp, where);
    return cp;
}

/// "entries": a whole number in [256, 65536].
inline std::size_t json_entries(const Json& n, const std::string& source) {
    const double v = n.is_number() ? n.get<double>() : -1.0;
    if (n.is_number())
        if (std::string why = float32_problem(v, n.dump()); !why.empty()) throw Error(source + ": \"entries\": " + why);
    if (!(v >= double(TransferFunction::min_entries) && v <= double(TransferFunction::max_entries)) || v != std::floor(v))
        throw Error(source + ": \"entries\" must be a whole number from 256 to 65536, found " + n.dump());
    return static_cast<std::size_t>(v);
}

/// Parses `text` as JSON (nlohmann-json: errors say line and column), refusing nesting deeper
/// than 64 levels and a "points" or "entries" key given twice at the top level (JSON allows
/// both; here they would hide a mistake).
inline Json parse_json(const std::string& text, const std::string& source) {
    std::vector<std::string> seen;
    auto check = [&](int depth, Json::parse_event_t event, Json& parsed) {
        if (depth > 64) throw Error(source + ": nested deeper than 64 levels");
        if (event == Json::parse_event_t::key && depth == 1 && parsed.is_string()) {
            const std::string& key = parsed.get_ref<const std::string&>();
            if (key == "points" || key == "entries") {
                if (std::find(seen.begin(), seen.end(), key) != seen.end())
                    throw Error(source + ": \"" + key + "\" given twice");
                seen.push_back(key);
            }
        }
        return true;
    };
    try {
        return Json::parse(text, check, /*allow_exceptions=*/true, /*ignore_comments=*/false);
    } catch (const Json::exception& e) {
        throw Error(source + ": " + e.what());
    }
}

}  // namespace detail::tf

inline TransferFunction TransferFunction::from_json(const std::filesystem::path& path) {
    const std::string source = "transfer function file " + path.string();
    detail::tf::Json doc = detail::tf::parse_json(detail::tf::read_text(path, "transfer function file"), source);
    if (!doc.is_object())
        throw Error(source + ": expected an object {\"points\": [...]}, found " + std::string(doc.type_name()));
    auto pts = doc.find("points");
    if (pts == doc.end()) throw Error(source + ": missing \"points\"");
    if (!pts->is_array()) throw Error(source + ": \"points\" must be an array of [d, r, g, b, a] arrays");
    if (pts->empty()) throw Error(source + ": \"points\" is empty");
    std::vector<ControlPoint> points;
    points.reserve(pts->size());
    for (std::size_t i = 0; i < pts->size(); ++i) points.push_back(detail::tf::json_point((*pts)[i], i, source));
    auto n = doc.find("entries");
    std::size_t entries = n == doc.end() ? default_entries : detail::tf::json_entries(*n, source);
    return TransferFunction(std::move(points), entries);
}
#else
inline TransferFunction TransferFunction::from_json(const std::filesystem::path& path) {
    throw Error("transfer function file " + path.string() +
                ": JSON needs nlohmann-json (Debian: nlohmann-json3-dev), which was not found when this was "
                "compiled; install it or use the text format");
}
#endif

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_TRANSFER_FUNCTION_HPP
