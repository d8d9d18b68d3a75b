// sylva/volume/nrrd.hpp -- NRRD volumes (teem's "nearly raw raster data", magic NRRD0001 to
// NRRD0005): a text header of "field: value" lines, then the voxels, either attached (after
// the blank line that ends the header, .nrrd) or in a separate file (`data file:`, .nhdr).
//
// What is read, and how:
//  * type: uchar/uint8 (also "unsigned char", "uint8_t"), ushort/uint16 ("unsigned short",
//    "unsigned short int", "uint16_t") and float are kept as they are. signed char/int8,
//    short/int16, int/int32, uint/uint32 and double are converted to float32 (range = data
//    min/max, as for float; 32-bit integers above 2^24 lose precision). 64-bit integers and
//    "block" are errors.
//  * dimension 3, or 4 with a leading axis of size 1 (one scalar per voxel); sizes in x, y, z
//    order, x fastest in the data.
//  * spacing from `spacings` or from diagonal `space directions` (the absolute value of each
//    diagonal entry: axis flips are ignored, the grid is always [0, dims * spacing]); any
//    off-diagonal entry is an error, and so are spacings that disagree with the directions.
//    No spacing given: (1, 1, 1).
//  * `min` and `max`, when given, are the volume's stated value range: by default it maps to
//    density [0, 1] instead of the data's own min/max (sylva/volume/value_range.hpp). `old
//    min`/`old max` (a range before quantisation) are ignored. `space origin`, `space`, `kinds`, `centers`, `content`,
//    key/value pairs (key:=value) and unknown fields are ignored.
//  * encoding raw, or gzip/gz (through zlib when sylva was built with it, SYLVA_HAVE_ZLIB=1;
//    otherwise an error says that gzip needs zlib). ascii/text/hex/bzip2 are errors.
//  * endian little/big (required for multi-byte types, as the format says).
//  * `data file:`/`datafile:` relative to the header's folder (or absolute); the multi-file
//    forms (LIST, format strings) are errors. `line skip` and `byte skip` (-1 = the data end
//    the file, raw only; for gzip the skip applies to the decompressed bytes) are honoured.
// Every malformed case throws sylva::Error naming the file and, for header problems, the line.
#ifndef SYLVA_VOLUME_NRRD_HPP
#define SYLVA_VOLUME_NRRD_HPP

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/read_raw.hpp"
#include "sylva/volume/value_range.hpp"

#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
#include <zlib.h>
#endif

namespace sylva::volume {

namespace detail::nrrd {

/// How a voxel is stored in the file, and what it becomes in memory.
struct FileType {
    std::size_t bytes = 1;
    enum class Kind : std::uint8_t { U8, U16, F32, I8, I16, I32, U32, F64 } kind = Kind::U8;
};

/// One header field: its value and the line it came from (for messages).
struct Field {
    std::string value;
    int line = 0;
};

/// The header as read: fields by lowercase name, where the data start, what names the file.
struct Header {
    std::string source;  ///< "NRRD file <path>", the prefix of every message
    std::filesystem::path path;
    std::map<std::string, Field> fields;  ///< field name (lowercase) -> value
    std::uintmax_t data_offset = 0;       ///< attached data: first byte after the blank line
    bool blank_line_seen = false;         ///< false: the header runs to the end of the file
};

inline std::string trim(std::string_view s) {
    std::size_t b = 0, e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return std::string(s.substr(b, e - b));
}

inline std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

/// Whitespace-separated words of `s`.
inline std::vector<std::string> words(std::string_view s) {
    std::vector<std::string> out;
    std::size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        std::size_t b = i;
        while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        if (i > b) out.emplace_back(s.substr(b, i - b));
    }
    return out;
}

/// At most `max` bytes of `s` for an error message: printable ASCII as is, every other byte
/// (control characters, terminal escapes, NUL, bytes >= 0x80) as \xHH, never raw.
inline std::string printable(std::string_view s, std::size_t max = 60) {
    static constexpr char hex[] = "0123456789abcdef";
    std::string out;
    for (std::size_t i = 0; i < s.size() && i < max; ++i) {
        auto c = static_cast<unsigned char>(s[i]);
        if (c >= 0x20 && c < 0x7f) {
            out.push_back(static_cast<char>(c));
        } else {
            out.append("\\x").push_back(hex[c >> 4]);
            out.push_back(hex[c & 15]);
        }
    }
    if (s.size() > max) out.append("...");
    return out;
}

/// Refuses a header line holding a control character (NUL, escape, ...; tab is allowed): NRRD
/// headers are text, and a NUL would cut a data file name short.
inline void check_text(const std::string& line, const std::string& source, int line_no) {
    for (std::size_t i = 0; i < line.size(); ++i) {
        auto c = static_cast<unsigned char>(line[i]);
        if ((c < 0x20 && c != '\t') || c == 0x7f)
            throw Error(source + ": header line " + std::to_string(line_no) + " holds a control character (" +
                        printable(line.substr(i, 1)) + " at column " + std::to_string(i + 1) + "): '" +
                        printable(line) + "'");
    }
}

/// Reads one header line (without "\n" or "\r\n") of at most 64 KiB; false at end of file.
inline bool read_line(std::istream& in, std::string& line, const std::string& source, int line_no) {
    line.clear();
    char c;
    while (in.get(c)) {
        if (c == '\n') break;
        if (line.size() >= (std::size_t{1} << 16))
            throw Error(source + ": header line " + std::to_string(line_no) +
                        " is longer than 64 KiB (not a NRRD header?)");
        line.push_back(c);
    }
    if (!in && line.empty()) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
}

/// Checks the magic line NRRD0001 ... NRRD0005.
inline void check_magic(const std::string& line, const std::string& source) {
    if (line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 || line[7] < '1' || line[7] > '9')
        throw Error(source + ": not a NRRD file (first line '" + printable(line, 40) +
                    "', expected NRRD0001 to NRRD0005)");
    if (line[7] > '5')
        throw Error(source + ": NRRD format version " + printable(line.substr(7)) + " is newer than 5 (unsupported)");
}

/// Adds one "field: value" line; comments and key:=value pairs are skipped.
inline void add_field_line(Header& h, const std::string& line, int line_no) {
    if (line.front() == '#') return;
    std::size_t colon = line.find(':');
    if (colon != std::string::npos && colon + 1 < line.size() && line[colon + 1] == '=') return;  // key:=value
    if (colon == std::string::npos || colon + 1 >= line.size() || line[colon + 1] != ' ')
        throw Error(h.source + ": line " + std::to_string(line_no) + " '" + printable(line) +
                    "' is not 'field: value', a key:=value pair or a # comment");
    std::string key = lower(trim(line.substr(0, colon)));
    if (key == "datafile") key = "data file";
    if (h.fields.count(key))
        throw Error(h.source + ": line " + std::to_string(line_no) + ": field '" + printable(key) + "' already given on line " +
                    std::to_string(h.fields[key].line));
    h.fields[key] = Field{trim(line.substr(colon + 2)), line_no};
}

/// Reads the header of `path` (up to the blank line or the end of the file).
inline Header read_header(const std::filesystem::path& path) {
    Header h;
    h.source = "NRRD file " + path.string();
    h.path = path;
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(h.source + ": cannot open it (missing or unreadable)");
    std::string line;
    if (!read_line(in, line, h.source, 1)) throw Error(h.source + ": empty file");
    check_magic(line, h.source);
    for (int line_no = 2;; ++line_no) {
        if (!read_line(in, line, h.source, line_no)) break;
        if (line.empty()) {
            h.blank_line_seen = true;
            h.data_offset = static_cast<std::uintmax_t>(in.tellg());
            break;
        }
        if (line_no > 10000) throw Error(h.source + ": header longer than 10000 lines");
        check_text(line, h.source, line_no);
        add_field_line(h, line, line_no);
    }
    return h;
}

/// The value of a required field, or an error naming it.
inline const Field& required(const Header& h, const std::string& key) {
    auto it = h.fields.find(key);
    if (it == h.fields.end()) throw Error(h.source + ": missing field '" + key + "'");
    return it->second;
}

inline const Field* optional_field(const Header& h, const std::string& key) {
    auto it = h.fields.find(key);
    return it == h.fields.end() ? nullptr : &it->second;
}

inline Error field_error(const Header& h, const Field& f, const std::string& key, const std::string& why) {
    return Error(h.source + ": line " + std::to_string(f.line) + ": field '" + key + ": " + printable(f.value, 80) +
                 "': " + why);
}

/// NRRD type names (as the format spells them) and how each is stored.
inline constexpr std::array<std::pair<std::string_view, FileType>, 28> type_names{{
    {"uchar", {1, FileType::Kind::U8}},
    {"unsigned char", {1, FileType::Kind::U8}},
    {"uint8", {1, FileType::Kind::U8}},
    {"uint8_t", {1, FileType::Kind::U8}},
    {"signed char", {1, FileType::Kind::I8}},
    {"int8", {1, FileType::Kind::I8}},
    {"int8_t", {1, FileType::Kind::I8}},
    {"ushort", {2, FileType::Kind::U16}},
    {"unsigned short", {2, FileType::Kind::U16}},
    {"unsigned short int", {2, FileType::Kind::U16}},
    {"uint16", {2, FileType::Kind::U16}},
    {"uint16_t", {2, FileType::Kind::U16}},
    {"short", {2, FileType::Kind::I16}},
    {"short int", {2, FileType::Kind::I16}},
    {"signed short", {2, FileType::Kind::I16}},
    {"signed short int", {2, FileType::Kind::I16}},
    {"int16", {2, FileType::Kind::I16}},
    {"int16_t", {2, FileType::Kind::I16}},
    {"int", {4, FileType::Kind::I32}},
    {"signed int", {4, FileType::Kind::I32}},
    {"int32", {4, FileType::Kind::I32}},
    {"int32_t", {4, FileType::Kind::I32}},
    {"uint", {4, FileType::Kind::U32}},
    {"unsigned int", {4, FileType::Kind::U32}},
    {"uint32", {4, FileType::Kind::U32}},
    {"uint32_t", {4, FileType::Kind::U32}},
    {"float", {4, FileType::Kind::F32}},
    {"double", {8, FileType::Kind::F64}},
}};

/// The file type named by the `type` field.
inline FileType file_type(const Header& h) {
    const Field& f = required(h, "type");
    std::string name = lower(f.value);
    for (const auto& [n, t] : type_names)
        if (name == n) return t;
    throw field_error(h, f, "type",
                      "unsupported voxel type (supported: uchar/uint8, ushort/uint16, float; int8, int16, int32, "
                      "uint32 and double become float32)");
}

/// Parses a whole number field value; false when it is not one.
inline bool parse_int(std::string_view s, long long& out) {
    if (s.empty()) return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size();
}

/// Parses a floating-point number ("nan" accepted, locale independent); false when it is not one.
inline bool parse_double(std::string_view s, double& out) {
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    if (s.empty()) return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size();
}

/// The grid: dimensions and spacing from dimension, sizes, spacings and space directions.
struct Geometry {
    Dims dims{0};
    vec3 spacing{1.0f};
};

/// Dimensions from `dimension` and `sizes` (3 axes, or 4 with a leading size 1).
inline Dims grid_dims(const Header& h) {
    const Field& fd = required(h, "dimension");
    long long dim = 0;
    if (!parse_int(fd.value, dim) || (dim != 3 && dim != 4))
        throw field_error(h, fd, "dimension", "only 3, or 4 with a leading size 1, is supported");
    const Field& fs = required(h, "sizes");
    std::vector<std::string> w = words(fs.value);
    if (static_cast<long long>(w.size()) != dim)
        throw field_error(h, fs, "sizes", std::to_string(w.size()) + " sizes for dimension " + std::to_string(dim));
    std::vector<std::uint32_t> sizes;
    for (const std::string& s : w) {
        long long v = 0;
        if (!parse_int(s, v) || v < 1 || v > 0xFFFFFFFFll)
            throw field_error(h, fs, "sizes", "'" + s + "' is not a size between 1 and 4294967295");
        sizes.push_back(static_cast<std::uint32_t>(v));
    }
    if (dim == 4 && sizes[0] != 1)
        throw field_error(h, fs, "sizes",
                          "a 4-D volume must have a leading size 1 (one scalar per voxel), not " + w[0]);
    std::size_t a = sizes.size() - 3;
    return Dims(sizes[a], sizes[a + 1], sizes[a + 2]);
}

/// True when a spacing read as a double is a positive normal float: from the smallest normal
/// float to the largest (a finite double beyond them would become infinity or 0 as a float).
inline bool float_spacing(double v) {
    return v >= static_cast<double>(std::numeric_limits<float>::min()) &&
           v <= static_cast<double>(std::numeric_limits<float>::max());
}

/// Spacing from `spacings` (the last three axes); nullopt when the field is absent.
inline std::optional<vec3> spacings(const Header& h, std::size_t axes) {
    const Field* f = optional_field(h, "spacings");
    if (!f) return std::nullopt;
    std::vector<std::string> w = words(f->value);
    if (w.size() != axes)
        throw field_error(h, *f, "spacings",
                          std::to_string(w.size()) + " values for " + std::to_string(axes) + " axes");
    vec3 s;
    for (int i = 0; i < 3; ++i) {
        double v = 0.0;
        if (!parse_double(w[axes - 3 + i], v) || !float_spacing(v))
            throw field_error(h, *f, "spacings",
                              "'" + w[axes - 3 + i] + "' is not a finite positive spacing (1.2e-38 to 3.4e38)");
        s[i] = static_cast<float>(v);
    }
    return s;
}

/// The vectors of `space directions`: "none" or "(a,b,c)" per axis.
inline std::vector<std::optional<glm::dvec3>> direction_vectors(const Header& h, const Field& f) {
    std::vector<std::optional<glm::dvec3>> out;
    std::string_view v = f.value;
    for (std::size_t i = 0; i < v.size();) {
        if (std::isspace(static_cast<unsigned char>(v[i]))) {
            ++i;
            continue;
        }
        if (v.compare(i, 4, "none") == 0) {
            out.emplace_back();
            i += 4;
            continue;
        }
        std::size_t close = v.find(')', i);
        if (v[i] != '(' || close == std::string_view::npos)
            throw field_error(h, f, "space directions", "expected '(x,y,z)' or 'none'");
        std::string inner(v.substr(i + 1, close - i - 1));
        std::replace(inner.begin(), inner.end(), ',', ' ');
        std::vector<std::string> c = words(inner);
        glm::dvec3 d;
        if (c.size() != 3) throw field_error(h, f, "space directions", "only 3-D space vectors are supported");
        for (int k = 0; k < 3; ++k)
            if (!parse_double(c[k], d[k]) || !std::isfinite(d[k]))
                throw field_error(h, f, "space directions", "'" + c[k] + "' is not a finite number");
        out.emplace_back(d);
        i = close + 1;
    }
    return out;
}

/// Spacing from diagonal `space directions`; nullopt when the field is absent.
inline std::optional<vec3> direction_spacing(const Header& h, std::size_t axes) {
    const Field* f = optional_field(h, "space directions");
    if (!f) return std::nullopt;
    auto dirs = direction_vectors(h, *f);
    if (dirs.size() != axes)
        throw field_error(h, *f, "space directions",
                          std::to_string(dirs.size()) + " entries for " + std::to_string(axes) + " axes");
    if (axes == 4 && dirs[0])
        throw field_error(h, *f, "space directions", "the leading (non-spatial) axis must be 'none'");
    vec3 s;
    for (int i = 0; i < 3; ++i) {
        const auto& d = dirs[axes - 3 + i];
        if (!d) throw field_error(h, *f, "space directions", "spatial axis " + std::to_string(i) + " is 'none'");
        double diag = std::abs((*d)[i]);
        for (int k = 0; k < 3; ++k)
            if (k != i && std::abs((*d)[k]) > 1e-6 * diag)
                throw field_error(h, *f, "space directions",
                                  "axis " + std::to_string(i) + " is not along the space axis " + std::to_string(i) +
                                      " (only diagonal directions, i.e. axis-aligned grids, are supported)");
        if (!(diag > 0.0))
            throw field_error(h, *f, "space directions", "axis " + std::to_string(i) + " has zero length");
        if (!float_spacing(diag))
            throw field_error(h, *f, "space directions",
                              "axis " + std::to_string(i) + " has a length outside 1.2e-38 to 3.4e38");
        s[i] = static_cast<float>(diag);
    }
    return s;
}

/// Dimensions and spacing of the grid.
inline Geometry geometry(const Header& h) {
    Geometry g;
    g.dims = grid_dims(h);
    std::size_t axes = words(required(h, "sizes").value).size();
    std::optional<vec3> from_spacings = spacings(h, axes), from_directions = direction_spacing(h, axes);
    if (from_spacings && from_directions &&
        glm::any(glm::greaterThan(glm::abs(*from_spacings - *from_directions), 1e-5f * *from_directions)))
        throw Error(h.source + ": 'spacings' and 'space directions' disagree");
    g.spacing = from_directions ? *from_directions : from_spacings.value_or(vec3(1.0f));
    return g;
}

/// The value range the header states (`min:` and `max:`, NRRD's "minimum and maximum values in
/// the array"); nullopt when it gives neither. One given alone leaves the other NaN, to be taken
/// from the data. Each must be a finite number, and min < max when both are given.
inline std::optional<std::pair<float, float>> stated_range(const Header& h) {
    const Field* fmin = optional_field(h, "min");
    const Field* fmax = optional_field(h, "max");
    if (!fmin && !fmax) return std::nullopt;
    auto value = [&](const Field* f, const char* key) {
        double d = 0.0;
        if (!f) return std::numeric_limits<float>::quiet_NaN();
        if (!parse_double(trim(f->value), d) || !std::isfinite(d) || std::fabs(d) > std::numeric_limits<float>::max())
            throw field_error(h, *f, key, "not a finite number");
        return static_cast<float>(d);
    };
    std::pair<float, float> r{value(fmin, "min"), value(fmax, "max")};
    if (fmin && fmax && !(r.first < r.second))
        throw field_error(h, *fmax, "max", "must be above min (" + printable(fmin->value, 40) + ")");
    return r;
}

/// True for gzip/gz, false for raw; an error for the other encodings.
inline bool gzip_encoding(const Header& h) {
    const Field& f = required(h, "encoding");
    std::string e = lower(f.value);
    if (e == "raw") return false;
    if (e == "gzip" || e == "gz") return true;
    throw field_error(h, f, "encoding", "unsupported encoding (supported: raw, gzip)");
}

/// True when multi-byte voxels are big-endian (`endian` is required for them).
inline bool big_endian(const Header& h, std::size_t width) {
    const Field* f = optional_field(h, "endian");
    if (!f) {
        if (width > 1)
            throw Error(h.source + ": missing field 'endian' (required for " + std::to_string(width) + "-byte voxels)");
        return false;
    }
    std::string e = lower(f->value);
    if (e != "little" && e != "big") throw field_error(h, *f, "endian", "must be 'little' or 'big'");
    return e == "big";
}

/// Where the voxels are: the file, the offset of the first data line, and the skips.
struct DataLocation {
    std::filesystem::path path;
    std::string source;         ///< names the data file (and the header when detached)
    std::uintmax_t offset = 0;  ///< where the data (before line/byte skips) start
    long long line_skip = 0;
    long long byte_skip = 0;  ///< -1: the data end the file (raw only)
};

inline long long skip_field(const Header& h, const std::string& key, long long lowest) {
    const Field* f = optional_field(h, key);
    long long v = 0;
    if (f && (!parse_int(f->value, v) || v < lowest))
        throw field_error(h, *f, key, "must be a whole number >= " + std::to_string(lowest));
    return v;
}

/// The data location: a detached `data file` (relative to the header's folder), else the
/// bytes after the header's blank line.
inline DataLocation data_location(const Header& h, bool gzip) {
    DataLocation d;
    d.line_skip = skip_field(h, "line skip", 0);
    d.byte_skip = skip_field(h, "byte skip", -1);
    if (d.byte_skip == -1 && gzip) throw Error(h.source + ": 'byte skip: -1' works only with raw encoding");
    const Field* f = optional_field(h, "data file");
    if (!f) {
        if (!h.blank_line_seen)
            throw Error(h.source + ": no data: no 'data file' field and no blank line followed by attached data");
        d.path = h.path;
        d.source = h.source;
        d.offset = h.data_offset;
        return d;
    }
    std::vector<std::string> w = words(f->value);
    if (w.size() != 1 || w[0] == "LIST")
        throw field_error(h, *f, "data file", "only a single data file is supported (not LIST or a format string)");
    std::filesystem::path p(f->value);
    d.path = p.is_absolute() ? p : h.path.parent_path() / p;
    d.source = h.source + " (data file " + d.path.string() + ")";
    return d;
}

/// Opens the data file at the data start, after `line skip` lines.
inline std::ifstream open_data(const DataLocation& d) {
    std::error_code ec;
    if (std::filesystem::is_directory(d.path, ec)) throw Error(d.source + ": the data file is a directory, not a file");
    std::ifstream in(d.path, std::ios::binary);
    if (!in) throw Error(d.source + ": cannot open the data file (missing or unreadable)");
    in.seekg(static_cast<std::streamoff>(d.offset));
    for (long long i = 0; i < d.line_skip; ++i)
        if (!in.ignore(std::numeric_limits<std::streamsize>::max(), '\n') || in.eof())
            throw Error(d.source + ": data end within the " + std::to_string(d.line_skip) + " skipped lines");
    return in;
}

/// Reads `need` raw bytes: after `byte skip` bytes, or the last `need` bytes for skip -1. The
/// data must fill the rest of the file exactly.
inline std::vector<std::byte> read_raw_data(const DataLocation& d, std::size_t need) {
    std::ifstream in = open_data(d);
    std::error_code ec;
    std::uintmax_t size = std::filesystem::file_size(d.path, ec);
    if (ec) throw Error(d.source + ": cannot read its size: " + ec.message());
    std::uintmax_t start = static_cast<std::uintmax_t>(in.tellg());
    if (d.byte_skip == -1)
        start = size >= need ? std::max(start, size - need) : start;
    else
        start += static_cast<std::uintmax_t>(d.byte_skip);
    std::uintmax_t have = size > start ? size - start : 0;
    if (have != need)
        throw Error(d.source + ": " + std::to_string(have) + " bytes of data, but the header asks for " +
                    std::to_string(need) + " (" + (have < need ? "truncated" : "too big") + ")");
    std::vector<std::byte> bytes(need);
    in.seekg(static_cast<std::streamoff>(start));
    if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(need)))
        throw Error(d.source + ": cannot read " + std::to_string(need) + " bytes of data");
    return bytes;
}

#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
/// Streams gzip data from a file through zlib's inflate. As gzip(1) reads them, several
/// concatenated gzip members are one stream (their contents follow each other). Bytes after the
/// last member that do not start another member, and zlib-wrapped data, are refused.
class GzipReader {
public:
    GzipReader(std::istream& in, std::string source, std::size_t expected)
        : in_(in), source_(std::move(source)), expected_(expected) {
        if (inflateInit2(&zs_, 15 + 16) != Z_OK)  // 16: gzip wrapper only (not zlib, not raw deflate)
            throw Error(source_ + ": zlib inflateInit2 failed");
    }
    GzipReader(const GzipReader&) = delete;
    GzipReader& operator=(const GzipReader&) = delete;
    ~GzipReader() { inflateEnd(&zs_); }

    /// Inflates exactly `n` bytes into `dst`; throws when the stream ends early or is corrupt.
    void read(std::byte* dst, std::size_t n) {
        while (n > 0) {
            if (member_done_ && !next_member())
                throw Error(source_ + ": gzip data hold only " + std::to_string(produced_) +
                            " bytes, but the header asks for " + std::to_string(expected_) + " (truncated)");
            std::size_t got = step(dst, std::min<std::size_t>(n, std::size_t{1} << 30));
            dst += got;
            n -= got;
        }
    }
    /// True when the data end here (every member's checksum verified, nothing after the last
    /// member); false when they hold more data. Throws on bytes that are no gzip member.
    bool finished() {
        std::byte probe[1];
        for (;;) {
            if (!member_done_) {
                if (step(probe, 1) == 1) return false;
            } else if (!next_member()) {
                return true;
            }
        }
    }

private:
    /// Makes at least `k` unread input bytes available if the file has them; false otherwise.
    bool fill(std::size_t k) {
        if (zs_.avail_in >= k) return true;
        if (zs_.avail_in > 0 && zs_.next_in != chunk_.data()) std::memmove(chunk_.data(), zs_.next_in, zs_.avail_in);
        zs_.next_in = chunk_.data();
        while (zs_.avail_in < k) {
            in_.read(reinterpret_cast<char*>(chunk_.data() + zs_.avail_in),
                     static_cast<std::streamsize>(chunk_.size() - zs_.avail_in));
            if (in_.gcount() == 0) return false;
            zs_.avail_in += static_cast<uInt>(in_.gcount());
        }
        return true;
    }
    /// True when bytes a, b open a zlib stream (RFC 1950: deflate method, header checksum).
    static bool zlib_header(unsigned a, unsigned b) { return (a & 0x0Fu) == 8u && (a >> 4) <= 7u && (a * 256u + b) % 31u == 0u; }
    /// At a member's end: true (inflate reset) when another gzip member follows, false at the
    /// end of the file; throws for any other byte.
    bool next_member() {
        if (!fill(2) && zs_.avail_in == 0) return false;
        if (zs_.avail_in >= 2 && zs_.next_in[0] == 0x1f && zs_.next_in[1] == 0x8b) {
            if (inflateReset(&zs_) != Z_OK) throw Error(source_ + ": zlib inflateReset failed");
            member_done_ = false;
            return true;
        }
        throw Error(source_ + ": the bytes after the gzip data (" + std::to_string(produced_) +
                    " bytes decompressed) are not a gzip member (trailing garbage)");
    }
    /// One inflate call into at most `room` bytes at `dst`; returns the bytes produced.
    std::size_t step(std::byte* dst, std::size_t room) {
        if (!started_) {  // name zlib-wrapped data for what they are
            started_ = true;
            if (fill(2) && !(zs_.next_in[0] == 0x1f && zs_.next_in[1] == 0x8b) &&
                zlib_header(zs_.next_in[0], zs_.next_in[1]))
                throw Error(source_ + ": the data are a zlib stream, not gzip ('encoding: gzip' needs gzip's 1f 8b header)");
        }
        if (zs_.avail_in == 0 && !fill(1))
            throw Error(source_ + ": gzip stream cut off after " + std::to_string(produced_) + " of " +
                        std::to_string(expected_) + " bytes (truncated file)");
        zs_.next_out = reinterpret_cast<Bytef*>(dst);
        zs_.avail_out = static_cast<uInt>(room);
        int r = inflate(&zs_, Z_NO_FLUSH);
        std::size_t got = room - zs_.avail_out;
        produced_ += got;
        if (r == Z_STREAM_END)
            member_done_ = true;
        else if (r != Z_OK && r != Z_BUF_ERROR)
            throw Error(source_ + ": corrupt gzip data (" + (zs_.msg ? zs_.msg : "zlib error " + std::to_string(r)) +
                        ")");
        return got;
    }

    std::istream& in_;
    std::string source_;
    std::size_t expected_;
    z_stream zs_{};
    std::vector<unsigned char> chunk_ = std::vector<unsigned char>(std::size_t{1} << 16);
    std::size_t produced_ = 0;
    bool member_done_ = false;
    bool started_ = false;
};
#endif

/// Inflates `need` bytes after `byte skip` decompressed bytes; the stream must end there.
inline std::vector<std::byte> read_gzip_data(const DataLocation& d, std::size_t need) {
#if defined(SYLVA_HAVE_ZLIB) && SYLVA_HAVE_ZLIB
    std::ifstream in = open_data(d);
    GzipReader gz(in, d.source, need);
    std::vector<std::byte> bytes(std::size_t{1} << 16);
    for (long long left = d.byte_skip; left > 0;) {  // skipped bytes go through a small scratch buffer
        std::size_t n = std::min<std::size_t>(bytes.size(), static_cast<std::size_t>(left));
        gz.read(bytes.data(), n);
        left -= static_cast<long long>(n);
    }
    // Grow with the data (64 MiB at a time): a header that claims far more voxels than a short
    // stream holds fails on the stream, not on one huge allocation.
    bytes.clear();
    for (std::size_t have = 0; have < need;) {
        std::size_t step = std::min<std::size_t>(need - have, std::size_t{1} << 26);
        try {
            bytes.resize(have + step);
        } catch (const std::bad_alloc&) {
            throw Error(d.source + ": cannot allocate " + std::to_string(need) + " bytes for the voxels");
        }
        gz.read(bytes.data() + have, step);
        have += step;
    }
    if (!gz.finished())
        throw Error(d.source + ": gzip data hold more than the " + std::to_string(need) +
                    " bytes the header asks for (too big)");
    return bytes;
#else
    (void)need;
    throw Error(d.source +
                ": gzip encoding needs zlib (sylva was built without it: install zlib1g-dev and reconfigure)");
#endif
}

/// Converts file voxels that sylva does not hold natively (int8/16/32, uint32, double) to float32.
template <class T>
std::vector<std::byte> to_float32(const std::vector<std::byte>& in) {
    std::vector<std::byte> out(in.size() / sizeof(T) * 4);
    for (std::size_t i = 0, n = in.size() / sizeof(T); i < n; ++i) {
        T v;
        std::memcpy(&v, &in[i * sizeof(T)], sizeof(T));
        float f = static_cast<float>(v);
        std::memcpy(&out[i * 4], &f, 4);
    }
    return out;
}

/// The volume of file voxels `bytes` (already in host byte order).
inline Volume make_volume(std::vector<std::byte> bytes, FileType t, const Geometry& g) {
    using K = FileType::Kind;
    Volume v;
    v.dims = g.dims;
    v.spacing = g.spacing;
    v.type = t.kind == K::U8 ? ScalarType::U8 : (t.kind == K::U16 ? ScalarType::U16 : ScalarType::F32);
    switch (t.kind) {
        case K::I8:
            v.bytes = to_float32<std::int8_t>(bytes);
            break;
        case K::I16:
            v.bytes = to_float32<std::int16_t>(bytes);
            break;
        case K::I32:
            v.bytes = to_float32<std::int32_t>(bytes);
            break;
        case K::U32:
            v.bytes = to_float32<std::uint32_t>(bytes);
            break;
        case K::F64:
            v.bytes = to_float32<double>(bytes);
            break;
        default:
            v.bytes = std::move(bytes);
    }
    return v;
}

}  // namespace detail::nrrd

/// Reads a NRRD volume (.nrrd with attached data, or a .nhdr header with a detached data file;
/// what is supported is listed at the top of this header). Throws sylva::Error naming the file
/// (and the header line) for every malformed or unsupported case: bad magic, missing or repeated
/// fields, unsupported type/dimension/encoding, non-diagonal space directions, missing data
/// file, truncated or oversized data, corrupt gzip streams, NaN or infinite float voxels, a
/// `min`/`max` that is not a finite number or min >= max. `range` picks the value range
/// (default Auto: the header's min/max where given, else the data's).
inline Volume read_nrrd(const std::filesystem::path& path, const ValueRange& range = {}) {
    using namespace detail::nrrd;
    Header h = read_header(path);
    FileType type = file_type(h);
    Geometry g = geometry(h);
    bool gzip = gzip_encoding(h);
    bool swap = big_endian(h, type.bytes);
    std::size_t need = detail::checked_voxel_count(g.dims, type.bytes, h.source) * type.bytes;
    DataLocation where = data_location(h, gzip);
    std::vector<std::byte> bytes = gzip ? read_gzip_data(where, need) : read_raw_data(where, need);
    if (swap) detail::swap_bytes(bytes, type.bytes);
    Volume v = make_volume(std::move(bytes), type, g);
    v.stated_range = stated_range(h);
    apply_value_range(v, range, h.source);
    return v;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_NRRD_HPP
