// sylva/volume/read.hpp -- one entry point for volume files: picks the reader by extension.
//   .nrrd, .nhdr  -> read_nrrd (sylva/volume/nrrd.hpp): spacing from the header
//   .raw          -> read_raw with the NAME_XxYxZ_TYPE.raw name convention (sylva/volume/read_raw.hpp):
//                    spacing (1, 1, 1) unless given
// Extensions are matched without regard to case.
#ifndef SYLVA_VOLUME_READ_HPP
#define SYLVA_VOLUME_READ_HPP

#include <cctype>
#include <filesystem>
#include <optional>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/nrrd.hpp"
#include "sylva/volume/read_raw.hpp"
#include "sylva/volume/value_range.hpp"

namespace sylva::volume {

/// Reads a volume file, choosing the reader by extension (.nrrd/.nhdr: NRRD; .raw: the
/// NAME_XxYxZ_TYPE.raw convention). `spacing`, when given, replaces the spacing the file or its
/// name implies (it must be finite and positive); `range` picks the value range that maps to
/// density [0, 1] (default Auto: the file's stated range, else the data's min/max). Throws sylva::Error for any other extension
/// (listing the accepted ones) and for everything the readers reject.
inline Volume read_volume(const std::filesystem::path& path, std::optional<vec3> spacing = {},
                          const ValueRange& range = {}) {
    std::string ext = path.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (spacing) detail::check_spacing(*spacing, "volume file " + path.string());
    if (ext == ".nrrd" || ext == ".nhdr") {
        Volume v = read_nrrd(path, range);
        if (spacing) v.spacing = *spacing;
        return v;
    }
    if (ext == ".raw") {
        RawInfo info = parse_raw_name(path.filename().string());
        if (spacing) info.spacing = *spacing;
        return read_raw(path, info, range);
    }
    throw Error(
        "volume file " + path.string() + ": unknown extension '" + ext +
        "' (accepted: .nrrd and .nhdr (NRRD), .raw named NAME_XxYxZ_TYPE.raw with TYPE uint8, uint16 or float32)");
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_READ_HPP
