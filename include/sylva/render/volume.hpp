// sylva/render/volume.hpp -- volume rendering on the host with the shared integrators the
// shaders run (sylva/shared/dvr.h, sylva/shared/bih_dvr.h), over all cores of an executor:
// the reference DVR marcher over a density grid, and single-sample, multi-sample and iso
// BIH-DVR over a voxel-cuboid BIH (Kinkelin sections 4.1, 4.3, 6.2).
//
//   VolumeRenderParams p;
//   p.camera = Camera::framing(grid.world_box()).frame(256, 256);
//   p.tf = my_rgba8_words;                                   // >= 2 entries
//   Frame ref = render_dvr_cpu(GridWords::from(grid), p, pool);
//   p.mode = VolumeMode::BihSingle;
//   Frame bih = render_bih_dvr_cpu(VoxelBihView{words, {}, grid.spacing, grid.world_box()}, p, pool);
//
// Both sides pack the parameters into the same word block (pack_volume_params; layout in
// sylva/shared/dvr_common.h) and decode it with the same shared function.
#ifndef SYLVA_RENDER_VOLUME_HPP
#define SYLVA_RENDER_VOLUME_HPP

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/grid_view.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/render/rays.hpp"
#include "sylva/shared/bih_dvr.h"
#include "sylva/shared/dvr.h"
#include "sylva/volume/grid.hpp"

namespace sylva {

/// Which integrator renders the volume.
enum class VolumeMode : std::uint32_t {
    DvrReference = SYLVA_VOLUME_MODE_DVR,     ///< ray marcher over the grid (Kinkelin 6.2)
    BihSingle = SYLVA_VOLUME_MODE_BIH_SINGLE,  ///< one sample per BIH leaf (Kinkelin 4.3)
    BihMulti = SYLVA_VOLUME_MODE_BIH_MULTI,    ///< the marcher's lattice inside each leaf (4.3)
    BihIso = SYLVA_VOLUME_MODE_BIH_ISO,        ///< first point reaching an iso value (4.1, 4.3)
};

/// The kinds of transfer function (sylva/shared/tf.h).
enum class TfKind : std::uint32_t {
    Rgba8 = SYLVA_TF_KIND_RGBA8,      ///< VolumeRenderParams::tf, RGBA8 words, >= 2 entries
    Rgba32f = SYLVA_TF_KIND_RGBA32F,  ///< VolumeRenderParams::tf_rgba32f, float RGBA, >= 1 entry
    Hook = SYLVA_TF_KIND_HOOK,        ///< VolumeRenderParams::tf_hook (host) / sylva_tf_user (GLSL)
};

/// Opacity correction of a sample (sylva/shared/dvr_classify.h).
enum class OpacityCorrection : std::uint32_t {
    Power = SYLVA_OPACITY_POWER,  ///< 1 - (1 - alpha)^(l / unit) (Kinkelin 4.3): images independent of dt
    None = SYLVA_OPACITY_NONE,    ///< alpha as each sample's opacity, whatever dt
};

/// Everything a volume image depends on besides the data.
struct VolumeRenderParams {
    CameraFrame camera{};
    /// Primary rays: the camera as pinhole (default) or orthographic, or the caller's rays
    /// (sylva/render/rays.hpp; parameter word 35).
    PixelRays rays{};
    std::uint32_t width = 256;
    std::uint32_t height = 256;
    /// Transfer function: straight RGBA8 words (R bits 0-7 ... A bits 24-31), entry i at
    /// density i / (N - 1), linear in between (sylva/shared/tf.h); N >= 2. Read for
    /// TfKind::Rgba8 (the default).
    std::vector<std::uint32_t> tf;
    /// Which transfer function classifies the samples (parameter word 36, sylva/shared/tf.h).
    TfKind tf_kind = TfKind::Rgba8;
    /// TfKind::Rgba32f: straight float RGBA, 4 floats an entry, any number of entries >= 1
    /// (entry i at density i / (N - 1), linear in between; one entry is a constant TF).
    std::vector<float> tf_rgba32f;
    /// TfKind::Hook on the host: straight RGBA of a normalised density, called from several
    /// threads at once. On Vulkan the hook is a GLSL function of your shader (sylva_tf_user,
    /// sylva/shared/tf.h; vk::render_dvr_vulkan with your kernel).
    std::function<vec4(float)> tf_hook;
    /// TfKind::Hook, optional: true when the hook may give some density in [lo, hi] an opacity
    /// above 0 (answer true when unsure). The octree's empty-node and octant tests read it, as
    /// a table of tf_skip_entries(p) entries (tf_opacity_prefix); without it a hook skips nothing.
    std::function<bool(float lo, float hi)> tf_hook_visible;
    /// Opacity correction (parameter word 37, sylva/shared/dvr_classify.h): Power (default)
    /// 1 - (1 - alpha)^(l / unit) per segment of length l; None: alpha per sample as it is.
    OpacityCorrection opacity = OpacityCorrection::Power;
    /// Lattice spacing in world units; 0 = the longest world extent / 1024 (Kinkelin 6.2:
    /// "1,024 steps along the longest axis of the volume").
    float dt = 0.0f;
    /// The TF's alpha is the opacity of a sample this long (world units); a segment of length
    /// l gets 1 - (1 - alpha)^(l / unit) (Kinkelin 4.3, opacity correction).
    float unit = 1.0f;
    /// Lambert + Blinn-Phong shading from the gradient (on the fly for the marcher, the leaf's
    /// for BIH-DVR).
    bool shading = false;
    /// Direction towards the light (normalised here); (0, 0, 0) = a headlight.
    vec3 light{0.0f};
    float ambient = 0.3f;
    float diffuse = 0.7f;
    float specular = 0.2f;
    float shininess = 32.0f;
    /// Early ray termination once the opacity reaches this (Kinkelin 5.3); > 1 never stops.
    float alpha_stop = 0.99f;
    /// Iso value (normalised density) of VolumeMode::BihIso.
    float iso = 0.5f;
    VolumeMode mode = VolumeMode::DvrReference;
    /// Iso mode: skip subtrees whose node-range maximum stays below the iso value (Kinkelin
    /// 4.1); needs VoxelBihView::ranges. The image is identical, the traversal shorter.
    bool iso_culling = false;
};

/// The longest world extent of `box` / 1024 (Kinkelin 6.2).
inline float default_dt(const Aabb& box) {
    vec3 e = box.extent();
    return std::max(e.x, std::max(e.y, e.z)) / 1024.0f;
}

/// A grid as the samplers read it (sylva/shared/grid_sample.h): words in the format of
/// `sampling` (float bits of normalised densities, or uint8 / uint16 raw values packed four /
/// two a word; sylva/render/grid_view.hpp) and the border mode (default constant 0).
struct GridWords {
    volume::Dims dims{0};
    vec3 spacing{1.0f};
    std::vector<std::uint32_t> words;
    GridSampling sampling{};

    /// Converts and checks a grid: dimensions >= 1, fewer than 2^32 voxels, as many values as
    /// voxels, all finite, spacing finite and > 0. Throws sylva::Error naming the problem.
    static GridWords from(const volume::DensityGrid& g, GridBorder border = {}) {
        std::size_t n = checked_count(g.dims, g.spacing);
        if (g.values.size() != n)
            throw Error("render: the grid holds " + std::to_string(g.values.size()) + " values for " +
                        std::to_string(n) + " voxels");
        border.check();
        GridWords out{g.dims, g.spacing, std::vector<std::uint32_t>(n), GridSampling{}};
        out.sampling.border = border;
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(g.values[i])) throw Error("render: grid value " + std::to_string(i) + " is not finite");
            out.words[i] = std::bit_cast<std::uint32_t>(g.values[i]);
        }
        return out;
    }
    /// A volume in its own voxel type, no float copy: uint8 / uint16 voxels packed into words
    /// (1 / 2 bytes a voxel), normalised on the fly with the volume's value range
    /// [range_lo, range_hi] exactly as volume::normalize does; a float32 volume is normalised
    /// (volume::normalize, 4 bytes a voxel). Throws sylva::Error for bad sizes or an empty range.
    static GridWords native(const volume::Volume& v, GridBorder border = {}) {
        if (v.type == volume::ScalarType::F32) return from(volume::normalize(v), border);
        checked_count(v.dims, v.spacing);
        GridWords out{v.dims, v.spacing, pack_voxel_words(v), GridSampling{}};
        out.sampling.format = native_format(v.type);
        out.sampling.value_lo = v.range_lo;
        out.sampling.value_span = v.range_hi - v.range_lo;
        out.sampling.border = border;
        out.sampling.check();
        return out;
    }
    /// An integer volume as sparse words (pack_sparse_words, sylva/render/grid_view.hpp): 8^3
    /// bricks, the uniform ones held by their value in the brick table, the others at 1 / 2
    /// bytes a voxel; the same densities as native(v), so the same images. Throws sylva::Error
    /// for a float32 volume, bad sizes or an empty range.
    static GridWords sparse(const volume::Volume& v, GridBorder border = {}) {
        checked_count(v.dims, v.spacing);
        GridWords out{v.dims, v.spacing, pack_sparse_words(v), GridSampling{}};
        out.sampling.format = v.type == volume::ScalarType::U8 ? GridFormat::SparseU8 : GridFormat::SparseU16;
        out.sampling.value_lo = v.range_lo;
        out.sampling.value_span = v.range_hi - v.range_lo;
        out.sampling.border = border;
        out.sampling.check();
        return out;
    }
    /// World box [0, dims * spacing].
    [[nodiscard]] Aabb world_box() const { return Aabb{vec3(0.0f), vec3(dims) * spacing}; }
    /// Voxel count.
    [[nodiscard]] std::size_t voxels() const { return volume::voxel_count(dims); }
    /// Words a dense grid needs in its format (sparse grids: the words they hold).
    [[nodiscard]] std::size_t expected_words() const {
        return is_sparse(sampling.format) ? words.size() : grid_word_count(sampling.format, voxels());
    }
    /// Checks the words against the format and dims: a dense grid's word count, a sparse grid's
    /// brick table (check_sparse_words). Throws sylva::Error naming the problem; `who` prefixes it.
    void check_words(const std::string& who) const {
        sampling.check();
        if (is_sparse(sampling.format)) {
            try {
                check_sparse_words(words, dims, sampling.format);
            } catch (const Error& e) {
                throw Error(who + ": " + e.what());
            }
        } else if (words.size() != expected_words()) {
            throw Error(who + ": GridWords holds " + std::to_string(words.size()) + " words for its dimensions (" +
                        std::to_string(expected_words()) + " expected)");
        }
    }
    /// Bytes of voxel data: voxels x 1 (uint8), 2 (uint16) or 4 (float32); a sparse grid's words
    /// (table and stored bricks).
    [[nodiscard]] std::size_t grid_bytes() const {
        return is_sparse(sampling.format) ? words.size() * 4 : voxels() * grid_voxel_bytes(sampling.format);
    }
    /// The shared sampler's descriptor.
    [[nodiscard]] shared::SylvaGridDesc desc() const { return sampling.desc(dims, spacing); }
    /// Normalised density of voxel i (i < voxels(), x fastest), as the samplers read it.
    [[nodiscard]] float density(std::size_t i) const {
        shared::Words w{words.data(), words.size()};
        if (!is_sparse(sampling.format))
            return shared::sylva_grid_word_density(w, desc(), static_cast<std::uint32_t>(i));
        std::size_t x = i % dims.x, y = (i / dims.x) % dims.y, z = i / (std::size_t{dims.x} * dims.y);
        return shared::sylva_grid_voxel_of(w, desc(), std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
    }

private:
    static std::size_t checked_count(volume::Dims dims, vec3 spacing) {
        std::size_t n = volume::voxel_count(dims, 4);
        if (n > 0xFFFFFFFFu) throw Error("render: a grid of " + std::to_string(n) + " voxels exceeds 2^32 - 1");
        if (!all_finite(spacing) || !(spacing.x > 0.0f && spacing.y > 0.0f && spacing.z > 0.0f))
            throw Error("render: grid spacing must be finite and > 0");
        return n;
    }
};

/// An encoded voxel-cuboid BIH (payload SYLVA_PAYLOAD_VOXEL) to render.
struct VoxelBihView {
    std::span<const std::uint32_t> words;
    /// Node-range buffer: one word per encoded node, bits 0-15 min and 16-31 max of the
    /// reconstructed density in the subtree (unorm16). Only read with iso culling.
    std::span<const std::uint32_t> ranges;
    /// World size of one voxel (the grid spacing the gradients refer to).
    vec3 voxel_size{1.0f};
    /// World box of the source grid, for the default dt (empty: the BIH's root box), so that
    /// multi-sample BIH-DVR and the marcher share one lattice.
    Aabb grid_box{};
};

namespace detail {

inline std::uint32_t fbits(float f) { return std::bit_cast<std::uint32_t>(f); }

inline void check_finite(float v, const char* what) {
    if (!std::isfinite(v)) throw Error(std::string("render: ") + what + " is not finite");
}

/// Throws sylva::Error for a transfer function the kind cannot use: an RGBA8 table of fewer than
/// 2 or more than 2^24 entries, a float table not whole entries, empty, over 2^24 entries or
/// not finite, a hook kind without a callable, an unknown kind or opacity correction.
inline void check_tf(const VolumeRenderParams& p) {
    if (p.tf_kind == TfKind::Rgba8) {
        if (p.tf.size() < 2 || p.tf.size() > (std::size_t{1} << 24))
            throw Error("render: the transfer function needs 2 to 2^24 entries, got " + std::to_string(p.tf.size()));
    } else if (p.tf_kind == TfKind::Rgba32f) {
        const std::vector<float>& t = p.tf_rgba32f;
        if (t.empty() || t.size() % 4 != 0 || t.size() / 4 > (std::size_t{1} << 24))
            throw Error("render: a float RGBA transfer function needs 1 to 2^24 whole entries of 4 floats, got " +
                        std::to_string(t.size()) + " floats");
        for (std::size_t i = 0; i < t.size(); ++i)
            if (!std::isfinite(t[i])) throw Error("render: float TF entry " + std::to_string(i / 4) + " is not finite");
    } else if (p.tf_kind == TfKind::Hook) {
        if (!p.tf_hook) throw Error("render: TfKind::Hook needs VolumeRenderParams::tf_hook on the host");
    } else {
        throw Error("render: unknown transfer function kind " + std::to_string(static_cast<std::uint32_t>(p.tf_kind)));
    }
    if (p.opacity != OpacityCorrection::Power && p.opacity != OpacityCorrection::None)
        throw Error("render: unknown opacity correction " + std::to_string(static_cast<std::uint32_t>(p.opacity)));
}

/// Throws sylva::Error for parameters no integrator can use.
inline void check_volume_params(const VolumeRenderParams& p) {
    if (p.width == 0 || p.height == 0 || std::uint64_t{p.width} * p.height > (std::uint64_t{1} << 28))
        throw Error("render: image size " + std::to_string(p.width) + "x" + std::to_string(p.height) +
                    " is empty or over 2^28 pixels");
    check_tf(p);
    for (const vec3& v : {p.camera.eye, p.camera.w, p.camera.u, p.camera.v, p.light})
        if (!all_finite(v)) throw Error("render: the camera or light holds a non-finite number");
    for (float f : {p.dt, p.unit, p.alpha_stop, p.iso, p.ambient, p.diffuse, p.specular, p.shininess})
        check_finite(f, "a volume parameter (dt, unit, alpha_stop, iso or shading weight)");
    if (p.dt < 0.0f) throw Error("render: dt must be > 0 (or 0 for the default)");
    if (!(p.unit > 0.0f)) throw Error("render: unit must be > 0");
    if (!(p.alpha_stop > 0.0f)) throw Error("render: alpha_stop must be > 0");
    check_rays(p.rays, p.width, p.height);
}

/// The resolved dt: p.dt, or default_dt(box); checks that the lattice index of the farthest
/// point of `box` stays below 2^24 (float lattice positions stay exact).
inline float resolve_dt(const VolumeRenderParams& p, const Aabb& box) {
    float dt = p.dt > 0.0f ? p.dt : default_dt(box);
    if (!(dt > 0.0f) || !std::isfinite(dt)) throw Error("render: dt resolves to 0 (empty volume box)");
    Aabb from = ray_origin_box(p.camera, p.rays, p.width, p.height);
    if (from.empty()) from = Aabb{box.lo, box.lo};
    vec3 far = glm::max(glm::max(glm::abs(box.lo - from.lo), glm::abs(box.hi - from.lo)),
                        glm::max(glm::abs(box.lo - from.hi), glm::abs(box.hi - from.hi)));
    double reach = glm::length(glm::dvec3(far));
    if (reach / dt >= 16777216.0)
        throw Error("render: dt " + std::to_string(dt) + " is too small for a volume " + std::to_string(reach) +
                    " away (more than 2^24 lattice steps)");
    return dt;
}

}  // namespace detail

/// Entries of p's table (parameter word 27): RGBA8 words, float entries (4 floats each), or 2
/// for the hook (no table; the octree's TF emptiness test then sees an always-visible TF).
inline std::uint32_t tf_entries(const VolumeRenderParams& p) {
    if (p.tf_kind == TfKind::Rgba32f) return static_cast<std::uint32_t>(p.tf_rgba32f.size() / 4);
    if (p.tf_kind == TfKind::Hook) return 2u;
    return static_cast<std::uint32_t>(p.tf.size());
}

/// Entries of the opacity table the octree's skipping reads (parameter word 43,
/// render/octree_volume.hpp: tf_opacity_prefix): the TF's own, or for a hook with
/// tf_hook_visible a table of kHookSkipEntries densities.
inline constexpr std::uint32_t kHookSkipEntries = 1024;
inline std::uint32_t tf_skip_entries(const VolumeRenderParams& p) {
    return (p.tf_kind == TfKind::Hook && p.tf_hook_visible) ? kHookSkipEntries : tf_entries(p);
}

/// The transfer function as the shared code reads it (buffer `tf`, sylva/shared/tf.h): the
/// table's words (RGBA8 words, or the float table's bits) and, for the hook, the callable.
struct TfWords {
    std::vector<std::uint32_t> words;
    const std::function<vec4(float)>* hook = nullptr;
    [[nodiscard]] shared::Words view() const { return shared::Words{words.data(), words.size(), hook}; }
};

/// p's TF as words (a copy of the table) for the host integrators and the device buffer.
inline TfWords tf_words(const VolumeRenderParams& p) {
    TfWords t;
    if (p.tf_kind == TfKind::Rgba32f) {
        t.words.resize(p.tf_rgba32f.size());
        for (std::size_t i = 0; i < t.words.size(); ++i) t.words[i] = std::bit_cast<std::uint32_t>(p.tf_rgba32f[i]);
    } else if (p.tf_kind == TfKind::Hook) {
        t.words.assign(1, 0u);
        t.hook = &p.tf_hook;
    } else {
        t.words = p.tf;
    }
    return t;
}

/// The parameter block of sylva/shared/dvr_common.h for `p` with the resolved dt, the grid
/// dims (marcher; 0 for BIH), the voxel size and the BIH word count (0 for the marcher).
inline std::vector<std::uint32_t> pack_volume_params(const VolumeRenderParams& p, volume::Dims dims, vec3 voxel_size,
                                                     float dt, std::uint32_t word_count) {
    std::vector<std::uint32_t> w(SYLVA_DVR_PARAM_WORDS, 0u);
    auto cam = p.camera.floats();
    for (std::size_t i = 0; i < cam.size(); ++i) w[i] = detail::fbits(cam[i]);
    vec3 light = glm::dot(p.light, p.light) > 0.0f ? glm::normalize(p.light) : vec3(0.0f);
    w[12] = p.width;
    w[13] = p.height;
    w[14] = static_cast<std::uint32_t>(p.mode);
    w[15] = (p.shading ? SYLVA_DVR_FLAG_SHADING : 0u) | (p.iso_culling ? SYLVA_DVR_FLAG_ISO_CULLING : 0u);
    const float f[11] = {dt, p.unit, p.alpha_stop, p.iso, light.x, light.y, light.z,
                         p.ambient, p.diffuse, p.specular, p.shininess};
    for (int i = 0; i < 11; ++i) w[16 + i] = detail::fbits(f[i]);
    w[27] = tf_entries(p);
    for (int a = 0; a < 3; ++a) {
        w[28 + a] = dims[a];
        w[31 + a] = detail::fbits(voxel_size[a]);
    }
    w[34] = word_count;
    w[35] = static_cast<std::uint32_t>(p.rays.source);
    w[36] = static_cast<std::uint32_t>(p.tf_kind);
    w[37] = static_cast<std::uint32_t>(p.opacity);
    w[43] = tf_skip_entries(p);
    return w;
}

namespace detail {

/// Checks and packs the marcher's parameters for a grid of `dims` voxels of size `spacing`.
inline std::vector<std::uint32_t> pack_dvr(volume::Dims dims, vec3 spacing, const VolumeRenderParams& p) {
    check_volume_params(p);
    Aabb box{vec3(0.0f), vec3(dims) * spacing};
    return pack_volume_params(p, dims, spacing, resolve_dt(p, box), 0u);
}

/// Checks the header of a voxel BIH of `word_count` words whose first words are `head`
/// (at least the header); throws sylva::Error naming the problem.
inline shared::SylvaBihHeader voxel_bih_header(std::span<const std::uint32_t> head, std::size_t word_count) {
    if (word_count > 0xFFFFFFFFu) throw Error("render: BIH encoding over 2^32 words");
    shared::SylvaBihHeader h =
        shared::sylva_bih_read_header(shared::Words{head.data(), head.size()}, static_cast<std::uint32_t>(word_count));
    if (h.valid == 0u) throw Error("render: not a valid encoded BIH (header, node count or depth)");
    if (((h.flags >> 8u) & 255u) != SYLVA_PAYLOAD_VOXEL)
        throw Error("render: the BIH's payload kind is " + std::to_string((h.flags >> 8u) & 255u) +
                    ", BIH-DVR needs voxel cuboids (" + std::to_string(SYLVA_PAYLOAD_VOXEL) + ")");
    return h;
}

/// Checks and packs BIH-DVR's parameters: a BIH mode, a finite voxel size > 0, and one range
/// word per node when iso culling is on (`range_count` words given).
inline std::vector<std::uint32_t> pack_bih_dvr(const shared::SylvaBihHeader& h, std::size_t word_count,
                                               vec3 voxel_size, const Aabb& grid_box, std::size_t range_count,
                                               const VolumeRenderParams& p) {
    check_volume_params(p);
    if (p.mode == VolumeMode::DvrReference) throw Error("render: BIH-DVR needs a BIH mode, not DvrReference");
    if (!all_finite(voxel_size) || !(voxel_size.x > 0.0f && voxel_size.y > 0.0f && voxel_size.z > 0.0f))
        throw Error("render: voxel size must be finite and > 0");
    if (p.iso_culling && p.mode == VolumeMode::BihIso && range_count != h.node_count)
        throw Error("render: iso culling needs one node-range word per node (" + std::to_string(h.node_count) +
                    "), got " + std::to_string(range_count));
    Aabb box = grid_box.empty() ? Aabb{h.root_lo, h.root_hi} : grid_box;
    return pack_volume_params(p, volume::Dims(0u), voxel_size, resolve_dt(p, box),
                              static_cast<std::uint32_t>(word_count));
}

}  // namespace detail

/// Packs and checks the parameters of the marcher over `grid`.
inline std::vector<std::uint32_t> dvr_params(const GridWords& grid, const VolumeRenderParams& p) {
    grid.check_words("render");
    std::vector<std::uint32_t> w = detail::pack_dvr(grid.dims, grid.spacing, p);
    grid.sampling.pack(w);
    return w;
}

/// Packs and checks the parameters of BIH-DVR over `bih`: a valid voxel BIH header, a BIH
/// mode, a finite voxel size > 0, and one range word per node when iso culling is on.
inline std::vector<std::uint32_t> bih_dvr_params(const VoxelBihView& bih, const VolumeRenderParams& p) {
    shared::SylvaBihHeader h = detail::voxel_bih_header(bih.words, bih.words.size());
    return detail::pack_bih_dvr(h, bih.words.size(), bih.voxel_size, bih.grid_box, bih.ranges.size(), p);
}

namespace detail {

/// Runs `ray(x, y, origin, direction, steps_out) -> rgba` for every pixel over the executor.
template <Executor X, class RayFn>
Frame render_pixels(const VolumeRenderParams& p, X& exec, RayFn&& ray) {
    auto start = std::chrono::steady_clock::now();
    std::size_t n = std::size_t{p.width} * p.height;
    Frame f{p.width, p.height, std::vector<vec4>(n), std::vector<std::uint32_t>(n), 0.0};
    parallel_take(exec, 0, p.height, kRowsPerTake, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y) {
            for (std::uint32_t x = 0; x < p.width; ++x) {
                Ray r = pixel_ray(p.camera, p.rays, x, static_cast<std::uint32_t>(y), p.width, p.height);
                std::size_t i = y * p.width + x;
                f.rgba[i] = ray(r.origin, r.direction, f.steps[i]);
            }
        }
    });
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return f;
}

}  // namespace detail

/// Renders `grid` with the reference marcher (p.mode is ignored); steps = lattice samples.
template <Executor X>
Frame render_dvr_cpu(const GridWords& grid, const VolumeRenderParams& p, X& exec) {
    std::vector<std::uint32_t> words = dvr_params(grid, p);
    TfWords tfw = tf_words(p);
    shared::Words pw{words.data(), words.size()}, gw{grid.words.data(), grid.words.size()}, tw = tfw.view();
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    return detail::render_pixels(p, exec, [&](vec3 o, vec3 d, std::uint32_t& steps) {
        return shared::sylva_dvr_march(gw, tw, sp, o, d, 0.0f, shared::sylva_inf(), steps);
    });
}

/// Convenience: converts `grid` (GridWords::from) and renders it with the marcher.
template <Executor X>
Frame render_dvr_cpu(const volume::DensityGrid& grid, const VolumeRenderParams& p, X& exec) {
    return render_dvr_cpu(GridWords::from(grid), p, exec);
}

/// Renders a voxel BIH in mode p.mode (BihSingle, BihMulti or BihIso); steps = iterator
/// node visits, 0xFFFFFFFF where the encoding was found corrupt.
template <Executor X>
Frame render_bih_dvr_cpu(const VoxelBihView& bih, const VolumeRenderParams& p, X& exec) {
    std::vector<std::uint32_t> words = bih_dvr_params(bih, p);
    TfWords tfw = tf_words(p);
    shared::Words pw{words.data(), words.size()}, bw{bih.words.data(), bih.words.size()},
        rw{bih.ranges.data(), bih.ranges.size()}, tw = tfw.view();
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    return detail::render_pixels(p, exec, [&](vec3 o, vec3 d, std::uint32_t& steps) {
        std::uint32_t status;
        vec4 c = shared::sylva_bih_volume_ray(bw, rw, tw, sp, o, d, 0.0f, shared::sylva_inf(), steps, status);
        if (status == SYLVA_ITER_ERROR) steps = 0xFFFFFFFFu;
        return c;
    });
}

/// What render_volume_cpu can draw: a grid for the marcher and/or a voxel BIH.
struct VolumeScene {
    const GridWords* grid = nullptr;
    VoxelBihView bih;
};

/// Renders `scene` with the integrator p.mode selects; throws sylva::Error when the scene
/// lacks what that mode reads.
template <Executor X>
Frame render_volume_cpu(const VolumeScene& scene, const VolumeRenderParams& p, X& exec) {
    if (p.mode == VolumeMode::DvrReference) {
        if (scene.grid == nullptr) throw Error("render: the reference marcher needs a grid");
        return render_dvr_cpu(*scene.grid, p, exec);
    }
    if (scene.bih.words.empty()) throw Error("render: BIH-DVR needs an encoded voxel BIH");
    return render_bih_dvr_cpu(scene.bih, p, exec);
}

}  // namespace sylva

#endif  // SYLVA_RENDER_VOLUME_HPP
