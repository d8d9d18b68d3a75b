// fuzz/harness/readers.hpp -- harnesses of the file readers: raw names and raw volumes, NRRD
// (attached, detached, gzip), transfer functions (text, JSON) and particle files. Bad input
// must end in sylva::Error; anything else (a crash, a sanitizer report, another exception, a
// result that breaks the reader's documented promise) is a finding.
#ifndef SYLVA_FUZZ_HARNESS_READERS_HPP
#define SYLVA_FUZZ_HARNESS_READERS_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#if SYLVA_HAVE_ZLIB
#include <zlib.h>
#endif

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/validate.hpp>
#include <sylva/core/error.hpp>
#include <sylva/io/particles.hpp>
#include <sylva/volume/nrrd.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/transfer_function.hpp>

#include "common.hpp"

namespace sylva_fuzz {

/// What every reader's Volume promises: dims > 0, bytes = voxels * width, a finite range.
inline void check_volume(const sylva::volume::Volume& v) {
    using namespace sylva::volume;
    SYLVA_FUZZ_CHECK(v.dims.x > 0 && v.dims.y > 0 && v.dims.z > 0, "a volume with a zero dimension");
    SYLVA_FUZZ_CHECK(v.bytes.size() == voxel_count(v.dims, scalar_bytes(v.type)) * scalar_bytes(v.type),
                     "voxel bytes do not match the dimensions");
    SYLVA_FUZZ_CHECK(std::isfinite(v.range_lo) && std::isfinite(v.range_hi), "a non-finite value range");
    SYLVA_FUZZ_CHECK(std::isfinite(v.spacing.x) && std::isfinite(v.spacing.y) && std::isfinite(v.spacing.z) &&
                         v.spacing.x > 0.0f && v.spacing.y > 0.0f && v.spacing.z > 0.0f,
                     "a spacing that is not finite and positive");
}

/// The whole input is a file name: parse_raw_name.
inline int fuzz_raw_name(const std::uint8_t* data, std::size_t size) {
    std::string_view name(reinterpret_cast<const char*>(data), size);
    try {
        sylva::volume::RawInfo info = sylva::volume::parse_raw_name(name);
        SYLVA_FUZZ_CHECK(info.type == sylva::volume::ScalarType::U8 || info.type == sylva::volume::ScalarType::U16 ||
                             info.type == sylva::volume::ScalarType::F32,
                         "an unknown voxel type parsed");
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// First line: the file name (NAME_XxYxZ_TYPE.raw); the rest: its bytes. Read through
/// read_volume, which picks the raw reader for .raw names (and NRRD for .nrrd/.nhdr ones).
inline int fuzz_raw(const std::uint8_t* data, std::size_t size) {
    Split s = split_line(data, size);
    std::string name = safe_name(s.head);
    ScratchFile file(name, s.rest.data(), s.rest.size());
    try {
        sylva::volume::Volume v = sylva::volume::read_volume(file.path());
        check_volume(v);
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// The input is an NRRD file with attached data (its header, a blank line, the data).
inline int fuzz_nrrd_attached(const std::uint8_t* data, std::size_t size) {
    ScratchFile file("v.nrrd", data, size);
    try {
        check_volume(sylva::volume::read_nrrd(file.path()));
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// The separator between a detached header and its data file in the nrrd_detached input.
inline constexpr std::string_view detached_separator = "\n--sylva-fuzz-data--\n";

/// The input is a detached header v.nhdr, detached_separator, then the bytes of the data file
/// v.raw beside it (the seeds name it with `data file: v.raw`).
inline int fuzz_nrrd_detached(const std::uint8_t* data, std::size_t size) {
    std::string_view all(reinterpret_cast<const char*>(data), size);
    std::size_t at = all.find(detached_separator);
    std::string_view header = all.substr(0, at);
    std::string_view body = at == std::string_view::npos ? std::string_view{} : all.substr(at + detached_separator.size());
    ScratchFile data_file("v.raw", body.data(), body.size());
    ScratchFile file("v.nhdr", header.data(), header.size());
    try {
        check_volume(sylva::volume::read_nrrd(file.path()));
    } catch (const sylva::Error&) {
    }
    return 0;
}

#if SYLVA_HAVE_ZLIB
/// `raw` as one gzip member (deflate with the gzip wrapper).
inline std::string gzip_bytes(std::string_view raw) {
    z_stream z{};
    SYLVA_FUZZ_CHECK(deflateInit2(&z, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) == Z_OK, "deflateInit2");
    std::string out(deflateBound(&z, static_cast<uLong>(raw.size())) + 32, '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
    z.avail_in = static_cast<uInt>(raw.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    SYLVA_FUZZ_CHECK(deflate(&z, Z_FINISH) == Z_STREAM_END, "deflate");
    out.resize(z.total_out);
    deflateEnd(&z);
    return out;
}
#endif

/// gzip-encoded NRRD. First byte even: the rest is the whole file as stored (header, blank
/// line, gzip stream: the decoder sees mutated streams). Odd: the rest is a header up to its
/// blank line and the voxel bytes, which the harness compresses (the fuzzer reaches what comes
/// after a good stream: sizes, types, ranges).
inline int fuzz_nrrd_gzip(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    std::string file(reinterpret_cast<const char*>(data + 1), size - 1);
#if SYLVA_HAVE_ZLIB
    if (data[0] & 1u) {
        std::size_t blank = file.find("\n\n");
        if (blank != std::string::npos) file = file.substr(0, blank + 2) + gzip_bytes(std::string_view(file).substr(blank + 2));
    }
#endif
    ScratchFile stored("v.nrrd", file.data(), file.size());
    try {
        check_volume(sylva::volume::read_nrrd(stored.path()));
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// What a transfer function promises: 256..65536 entries, each component in [0, 1].
inline void check_tf(const sylva::volume::TransferFunction& tf) {
    using sylva::volume::TransferFunction;
    SYLVA_FUZZ_CHECK(tf.size() >= TransferFunction::min_entries && tf.size() <= TransferFunction::max_entries,
                     "entry count out of range");
    for (const sylva::vec4& e : tf.entries())
        for (int c = 0; c < 4; ++c) SYLVA_FUZZ_CHECK(e[c] >= 0.0f && e[c] <= 1.0f, "an entry outside [0, 1]");
    for (float d : {-1.0f, 0.0f, 0.3f, 1.0f, 2.0f}) {
        sylva::vec4 v = tf.at(d);
        SYLVA_FUZZ_CHECK(std::isfinite(v.r) && std::isfinite(v.a), "a non-finite lookup");
    }
    SYLVA_FUZZ_CHECK(tf.packed_rgba8().size() == tf.size(), "packed table size");
}

/// The input is a transfer-function text file.
inline int fuzz_tf_text(const std::uint8_t* data, std::size_t size) {
    ScratchFile file("tf.txt", data, size);
    try {
        check_tf(sylva::volume::TransferFunction::from_text(file.path()));
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// The input is a transfer-function JSON file.
inline int fuzz_tf_json(const std::uint8_t* data, std::size_t size) {
    ScratchFile file("tf.json", data, size);
    try {
        check_tf(sylva::volume::TransferFunction::from_json(file.path()));
    } catch (const sylva::Error&) {
    }
    return 0;
}

/// First line: the file name (NAME_Nx3_float32.raw or anything); the rest: its bytes. Read with
/// read_points, turned into spheres; small sets are then built into a BIH, whose encoding must
/// validate and walk to the end (the builder's output is trusted by everything after it).
inline int fuzz_particles(const std::uint8_t* data, std::size_t size) {
    Split s = split_line(data, size);
    std::vector<sylva::vec3> points;
    try {
        ScratchFile file(safe_name(s.head), s.rest.data(), s.rest.size());
        points = sylva::io::read_points(file.path().string());
    } catch (const sylva::Error&) {
        return 0;
    }
    SYLVA_FUZZ_CHECK(points.size() * 12 == s.rest.size(), "point count does not match the file size");
    std::vector<sylva::Sphere> spheres;
    try {
        spheres = sylva::io::spheres_from_points(points);
    } catch (const sylva::Error&) {
        return 0;
    }
    SYLVA_FUZZ_CHECK(spheres.size() == points.size(), "a sphere per point");
    if (spheres.size() > 64) return 0;
    std::span<const sylva::Sphere> es(spheres);
    sylva::bih::Tree tree;
    try {
        tree = sylva::bih::build(es);
    } catch (const sylva::Error&) {
        return 0;  // the builder may refuse a scene (reported, e.g. extents past float32)
    }
    std::vector<std::uint32_t> words = sylva::bih::encode(tree, es, sylva::bih::RangePayload{});
    try {
        sylva::bih::validate(words, es.size());
    } catch (const sylva::Error& e) {
        SYLVA_FUZZ_CHECK(false, e.what());  // the encoder wrote what the validator refuses
    }
    sylva::Aabb box;
    for (const sylva::Sphere& p : spheres) box.extend(p.bounds());
    for (const sylva::Ray& r : rays_over(box.lo, box.hi)) {
        sylva::bih::LeafIterator it(words, r);
        std::size_t n = 0;
        while (auto hit = it.next()) {
            auto [first, count] = sylva::bih::decode_range(hit->payload);
            SYLVA_FUZZ_CHECK(std::uint64_t{first} + count <= es.size(), "a leaf range past the elements");
            SYLVA_FUZZ_CHECK(++n <= tree.nodes.size(), "more leaves than nodes");
        }
        SYLVA_FUZZ_CHECK(it.status() == SYLVA_ITER_DONE, "a built tree's walk did not end cleanly");
    }
    return 0;
}

}  // namespace sylva_fuzz

#endif  // SYLVA_FUZZ_HARNESS_READERS_HPP
