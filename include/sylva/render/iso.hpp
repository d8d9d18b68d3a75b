// sylva/render/iso.hpp -- exact isosurface rendering on the host (sylva/shared/iso_render.h):
// the implicit kd-tree (Wald et al.) or the reference cell DDA finds the candidate cells, the
// exact cubic root in each gives the hit; several isovalues, each with a colour and opacity,
// are composited front to back.
//
//   ikd::Tree t = ikd::build(grid, pool);
//   std::vector<std::uint32_t> words = ikd::encode(t);
//   IsoRenderParams p;  p.camera = ...;  p.isos = {{0.5f, vec4(0.9f, 0.8f, 0.7f, 1.0f)}};
//   IsoCounters n;
//   Frame f = render_iso_cpu(words, GridWords::from(grid), p, pool, &n);
//   // or GridWords::native(volume): a uint8 / uint16 volume read at 1 / 2 bytes a sample
#ifndef SYLVA_RENDER_ISO_HPP
#define SYLVA_RENDER_ISO_HPP

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/ikd/packet.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/rays.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/iso_render.h"
#include "sylva/volume/transfer_function.hpp"

namespace sylva {

/// Which walker finds the candidate cells.
enum class IsoWalker : std::uint32_t {
    Tree = SYLVA_ISO_WALK_TREE,  ///< the implicit min/max kd-tree (culls cells that cannot hold an isovalue)
    Dda = SYLVA_ISO_WALK_DDA,    ///< every cell along the ray (Amanatides-Woo): the reference
};

/// One isosurface: its normalised density and its colour (alpha = opacity; 1 = opaque).
struct IsoSurface {
    float value = 0.5f;
    vec4 rgba{0.9f, 0.85f, 0.75f, 1.0f};
};

/// Everything an isosurface image depends on besides the data.
struct IsoRenderParams {
    CameraFrame camera{};
    /// Primary rays: the camera as pinhole (default) or orthographic, or the caller's rays
    /// (sylva/render/rays.hpp; parameter word 29).
    PixelRays rays{};
    std::uint32_t width = 256;
    std::uint32_t height = 256;
    std::vector<IsoSurface> isos = std::vector<IsoSurface>(1);  ///< 1 .. 4 surfaces (default: one, 0.5)
    IsoWalker walker = IsoWalker::Tree;
    float alpha_stop = 0.99f;  ///< a ray ends once its opacity reaches this
    float ambient = 0.25f;
    float diffuse = 0.75f;
    /// What lies outside the grid (parameter words 33-34). Empty (the default): nothing, the
    /// grid's cells only, as Wald's tree holds them: a surface that reaches a face stays open
    /// there. A value: samples outside the grid read this normalised density (0 is NanoVDB's
    /// background and VTK's constant border), so the cells between the faces and those samples
    /// are walked too (sylva/shared/iso_shell.h) and surfaces close at the faces. The grid's own
    /// GridWords::sampling.border is the DVR samplers' and is not read here: a clamped border
    /// would extrude the face's surfaces to infinity.
    std::optional<float> border;
};

/// Totals over a frame (Wald's Table I and II counts): traversal steps, candidate cells
/// intersected, surface hits.
struct IsoCounters {
    std::uint64_t steps = 0, cells = 0, hits = 0, errors = 0;
    /// Packets only: active rays summed over the packet steps (lane_steps / steps = the average
    /// number of rays active in a step); single rays leave it 0.
    std::uint64_t lane_steps = 0;
};

/// The implicit kd-tree's walkers read dense grids (GridWords::from, or GridWords::native of a
/// uint8 / uint16 volume: 1 / 2 bytes a sample, normalised on the fly exactly as
/// volume::normalize does, so the same hits). Throws sylva::Error naming the format of a sparse
/// grid, and for a bad range or word count.
inline void check_iso_grid(const GridWords& grid) {
    if (is_sparse(grid.sampling.format))
        throw Error("render: the implicit kd-tree reads dense grids (float32, uint8 or uint16 words), not the sparse "
                    "format " + std::to_string(static_cast<std::uint32_t>(grid.sampling.format)));
    grid.check_words("render");
}

/// The shared parameter block of `p` for a tree of `tree_words` and a grid of `grid_words`
/// words in format and range `sampling` (layout: sylva/shared/iso_render.h); with a border,
/// `border_faces` are the faces whose shell cells are walked (iso_border_faces; all by
/// default, which is always correct). Throws
/// sylva::Error for 0 or more than 4 surfaces, a value or colour that is not finite, an empty
/// image, a sparse or unknown format, a border value that is not finite.
inline std::vector<std::uint32_t> iso_params(const IsoRenderParams& p, std::size_t tree_words, std::size_t grid_words,
                                             const GridSampling& sampling = {}, std::uint32_t border_faces = 0x3Fu) {
    if (p.isos.empty() || p.isos.size() > 4)
        throw Error("render: " + std::to_string(p.isos.size()) + " isovalues; 1 to 4 can be rendered at once");
    if (p.width == 0 || p.height == 0) throw Error("render: empty image");
    for (const vec3& v : {p.camera.eye, p.camera.w, p.camera.u, p.camera.v})
        if (!all_finite(v)) throw Error("render: the camera holds a non-finite number");
    check_rays(p.rays, p.width, p.height);
    sampling.check();
    if (is_sparse(sampling.format))
        throw Error("render: the implicit kd-tree reads dense grids (float32, uint8 or uint16 words)");
    std::vector<std::uint32_t> w(SYLVA_ISO_PARAM_WORDS, 0u);
    std::array<float, 12> cam = p.camera.floats();
    for (int i = 0; i < 12; ++i) w[i] = std::bit_cast<std::uint32_t>(cam[i]);
    w[12] = p.width;
    w[13] = p.height;
    w[14] = static_cast<std::uint32_t>(p.isos.size());
    w[15] = static_cast<std::uint32_t>(p.walker);
    for (std::size_t k = 0; k < p.isos.size(); ++k) {
        const IsoSurface& s = p.isos[k];
        if (!std::isfinite(s.value) || !all_finite(s.rgba))
            throw Error("render: isovalue " + std::to_string(k) + " or its colour is not finite");
        w[16 + k] = std::bit_cast<std::uint32_t>(s.value);
        w[20 + k] = volume::TransferFunction::pack_rgba8(glm::clamp(s.rgba, vec4(0.0f), vec4(1.0f)));
    }
    w[24] = std::bit_cast<std::uint32_t>(p.alpha_stop);
    w[25] = std::bit_cast<std::uint32_t>(p.ambient);
    w[26] = std::bit_cast<std::uint32_t>(p.diffuse);
    if (tree_words > 0xFFFFFFFFu || grid_words > 0xFFFFFFFFu) throw Error("render: buffers over 2^32 words");
    w[27] = static_cast<std::uint32_t>(tree_words);
    w[28] = static_cast<std::uint32_t>(grid_words);
    w[29] = static_cast<std::uint32_t>(p.rays.source);
    w[30] = static_cast<std::uint32_t>(sampling.format);
    w[31] = std::bit_cast<std::uint32_t>(sampling.format == GridFormat::F32 ? 0.0f : sampling.value_lo);
    w[32] = std::bit_cast<std::uint32_t>(sampling.format == GridFormat::F32 ? 1.0f : sampling.value_span);
    if (p.border) {
        if (!std::isfinite(*p.border)) throw Error("render: the isosurface border value is not finite");
        w[33] = SYLVA_ISO_BORDER_CONSTANT;
        w[34] = std::bit_cast<std::uint32_t>(*p.border);
        w[35] = border_faces & 0x3Fu;
    }
    return w;
}

/// [min, max] of the normalised densities on each face of a grid: face 2a holds the samples with
/// index 0 on axis a, face 2a + 1 those with the last index (order -x, +x, -y, +y, -z, +z).
struct IsoFaceRanges {
    std::array<float, 6> lo{}, hi{};
};

/// The face ranges of `grid` (the grid the encoded tree `words` was built over), read as the
/// tracers read it (sylva_shell_sample). A header the reader refuses gives [-inf, +inf] for
/// every face (all walked; the tracers then report the error).
inline IsoFaceRanges iso_face_ranges(std::span<const std::uint32_t> words, const GridWords& grid) {
    IsoFaceRanges r;
    const float inf = std::numeric_limits<float>::infinity();
    r.lo.fill(-inf);
    r.hi.fill(inf);
    shared::Words tw{words.data(), words.size()}, gw{grid.words.data(), grid.words.size()};
    const GridSampling& gs = grid.sampling;
    const bool f32 = gs.format == GridFormat::F32;
    shared::SylvaIkdHeader h = shared::sylva_ikd_read_header_grid(
        tw, static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)),
        static_cast<std::uint32_t>(std::min<std::size_t>(grid.words.size(), 0xFFFFFFFFu)),
        static_cast<std::uint32_t>(gs.format), f32 ? 0.0f : gs.value_lo, f32 ? 1.0f : gs.value_span);
    if (h.valid == 0u) return r;
    const std::array<std::int32_t, 3> n{static_cast<std::int32_t>(h.cells.x), static_cast<std::int32_t>(h.cells.y),
                                        static_cast<std::int32_t>(h.cells.z)};  // the last sample index
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            float lo = inf, hi = -inf;
            glm::ivec3 v(0);
            v[a] = side == 0 ? 0 : n[a];
            for (v[c] = 0; v[c] <= n[c]; ++v[c])
                for (v[b] = 0; v[b] <= n[b]; ++v[b]) {
                    float d = shared::sylva_shell_sample(gw, h, v, 0.0f);
                    lo = std::min(lo, d);
                    hi = std::max(hi, d);
                }
            r.lo[2 * a + side] = lo;
            r.hi[2 * a + side] = hi;
        }
    }
    return r;
}

/// The faces (bits of parameter word 35) whose densities, together with p's border value, span
/// one of p's isovalues: the shell cells beside the others cannot hold a surface (iso_shell.h).
/// 0 without a border.
inline std::uint32_t iso_border_faces(const IsoFaceRanges& r, const IsoRenderParams& p) {
    if (!p.border || p.isos.empty() || p.isos.size() > 4) return p.border ? 0x3Fu : 0u;
    vec4 isos(0.0f);
    for (std::size_t k = 0; k < p.isos.size(); ++k) isos[static_cast<int>(k)] = p.isos[k].value;
    std::uint32_t bits = 0;
    for (std::uint32_t f = 0; f < 6; ++f) {
        float lo = std::min(r.lo[f], *p.border), hi = std::max(r.hi[f], *p.border);
        if (shared::sylva_ikd_holds(isos, static_cast<std::uint32_t>(p.isos.size()), lo, hi)) bits |= 1u << f;
    }
    return bits;
}

namespace detail {

/// A frame of p's size, every pixel transparent with 0 steps.
inline Frame iso_frame(const IsoRenderParams& p) {
    Frame f;
    f.width = p.width;
    f.height = p.height;
    f.rgba.assign(std::size_t{p.width} * p.height, vec4(0.0f));
    f.steps.assign(f.rgba.size(), 0u);
    return f;
}

/// IsoCounters summed over the executor's workers.
struct IsoTotals {
    std::atomic<std::uint64_t> steps{0}, cells{0}, hits{0}, errors{0}, lane_steps{0};
    void add(const IsoCounters& n) {
        steps += n.steps;
        cells += n.cells;
        hits += n.hits;
        errors += n.errors;
        lane_steps += n.lane_steps;
    }
    [[nodiscard]] IsoCounters get() const {
        return {steps.load(), cells.load(), hits.load(), errors.load(), lane_steps.load()};
    }
};

/// Traces pixel (x, y): the camera's ray through the shared sylva_iso_pixel, or the caller's ray
/// (PixelRays::buffer or ::generate) through sylva_iso_trace_ray, as the shader does.
inline shared::SylvaIsoRay iso_pixel(shared::Words tw, shared::Words gw, const shared::SylvaIsoParams& sp,
                                     const shared::SylvaIkdHeader& hdr, const IsoRenderParams& p, std::uint32_t x,
                                     std::uint32_t y) {
    if (p.rays.source != RaySource::Buffer) return shared::sylva_iso_pixel(tw, gw, sp, hdr, x, y);
    Ray r = pixel_ray(p.camera, p.rays, x, y, p.width, p.height);
    return shared::sylva_iso_trace_ray(tw, gw, sp, hdr, shared::SylvaRay{r.origin, r.direction});
}

/// Adds one traced ray to the pixel at i and to the counters.
inline void iso_store(const shared::SylvaIsoRay& r, std::size_t i, Frame& f, IsoCounters& n) {
    f.rgba[i] = r.rgba;
    f.steps[i] = r.status == SYLVA_ITER_ERROR ? 0xFFFFFFFFu : r.steps;
    n.steps += r.steps;
    n.cells += r.cells;
    n.hits += r.hits;
    n.errors += r.status == SYLVA_ITER_ERROR ? 1u : 0u;
}

}  // namespace detail

/// Renders the isosurfaces of an encoded implicit kd-tree (ikd::encode) over `grid` (the
/// GridWords of the grid it was built from: GridWords::from, or GridWords::native of the
/// uint8 / uint16 volume that grid was normalised from) on the host. Frame::steps holds each pixel's
/// traversal steps (0xFFFFFFFF where the encoding was refused); `counters`, when given, gets
/// the totals. Throws sylva::Error for bad parameters.
template <Executor X>
Frame render_iso_cpu(std::span<const std::uint32_t> words, const GridWords& grid, const IsoRenderParams& p, X& exec,
                     IsoCounters* counters = nullptr) {
    check_iso_grid(grid);
    std::uint32_t faces = p.border ? iso_border_faces(iso_face_ranges(words, grid), p) : 0u;  // once a frame
    std::vector<std::uint32_t> params = iso_params(p, words.size(), grid.words.size(), grid.sampling, faces);
    shared::Words pw{params.data(), params.size()}, tw{words.data(), words.size()}, gw{grid.words.data(), grid.words.size()};
    shared::SylvaIsoParams sp = shared::sylva_iso_read_params(pw);
    shared::SylvaIkdHeader hdr = shared::sylva_iso_read_header(tw, sp);  // once a frame
    Frame f = detail::iso_frame(p);
    detail::IsoTotals totals;
    auto start = std::chrono::steady_clock::now();
    parallel_take(exec, 0, p.height, kRowsPerTake, [&](std::size_t y0, std::size_t y1) {
        IsoCounters n;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::uint32_t x = 0; x < p.width; ++x)
                detail::iso_store(detail::iso_pixel(tw, gw, sp, hdr, p, x, static_cast<std::uint32_t>(y)),
                                  y * p.width + x, f, n);
        totals.add(n);
    });
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (counters) *counters = totals.get();
    return f;
}

namespace detail {

/// Pixels across the tile of a packet of L rays: 2x2 tiles for 4, 4x2 for 8, 4x4 for 16.
constexpr int packet_tile_width(int lanes) { return lanes == 4 ? 2 : 4; }

/// The camera rays (pinhole or ortho: sylva_camera_ray) of the tile at (x0, y0), directions
/// normalised as iso_tile's caller's rays are, four lanes at a time in ikd's F4 operations: the
/// scalar expressions' operations in the same order, so the same bits. Lanes past the image
/// edge get rays of pixels outside it (the caller leaves them inactive).
template <int L>
void tile_camera_rays(const CameraFrame& cam, RaySource source, std::uint32_t x0, std::uint32_t y0, std::uint32_t width,
                      std::uint32_t height, ikd::BasicRayPacket<L>& pk) {
    using namespace ikd::detail;
    constexpr int kTileWidth = packet_tile_width(L);
    const F4 half = set4(0.5f), two = set4(2.0f), one = set4(1.0f), fw = set4(float(width)), fh = set4(float(height));
    for (int g = 0; g < L / 4; ++g) {
        alignas(16) float px[4], py[4];
        for (int i = 0; i < 4; ++i) {
            int k = 4 * g + i;
            px[i] = float(x0 + static_cast<std::uint32_t>(k % kTileWidth));
            py[i] = float(y0 + static_cast<std::uint32_t>(k / kTileWidth));
        }
        // sylva_camera_plane: sx = (x + 0.5) / width * 2 - 1, sy = 1 - (y + 0.5) / height * 2.
        F4 sx = sub4(mul4(div4(add4(load4(px), half), fw), two), one);
        F4 sy = sub4(one, mul4(div4(add4(load4(py), half), fh), two));
        // a + sx u + sy v, per axis (sylva_camera_dir / sylva_camera_offset).
        vec3 a = source == RaySource::Ortho ? cam.eye : cam.w;
        F4 c[3];
        for (int ax = 0; ax < 3; ++ax)
            c[ax] = add4(add4(set4(a[ax]), mul4(sx, set4(cam.u[ax]))), mul4(sy, set4(cam.v[ax])));
        alignas(16) float o[3][4], d[3][4];
        if (source == RaySource::Ortho) {
            for (int ax = 0; ax < 3; ++ax) {
                store4(o[ax], c[ax]);
                store4(d[ax], set4(cam.w[ax]));
            }
        } else {
            for (int ax = 0; ax < 3; ++ax) {
                store4(o[ax], set4(cam.eye[ax]));
                store4(d[ax], c[ax]);
            }
        }
        // Normalised as by the scalar path: len = sqrt(x x + y y + z z), d / len.
        F4 dx = load4(d[0]), dy = load4(d[1]), dz = load4(d[2]);
        F4 len = sqrt4(add4(add4(mul4(dx, dx), mul4(dy, dy)), mul4(dz, dz)));
        store4(d[0], div4(dx, len));
        store4(d[1], div4(dy, len));
        store4(d[2], div4(dz, len));
        for (int i = 0; i < 4; ++i) {
            pk.origin[4 * g + i] = vec3(o[0][i], o[1][i], o[2][i]);
            pk.direction[4 * g + i] = vec3(d[0][i], d[1][i], d[2][i]);
        }
    }
}

/// Shades the tile at (x0, y0) with one packet of L rays (ikd::BasicPacketIter<L>; tiles of
/// packet_tile_width(L) x L / packet_tile_width(L) pixels); lanes outside the image stay
/// inactive. Falls back to single rays when the directions' signs differ. Adds the packet's
/// traversal steps (or the single rays') to n.
template <int L>
void iso_tile(shared::Words tw, shared::Words gw, const shared::SylvaIsoParams& sp, const shared::SylvaIkdHeader& hdr,
              const ikd::IsoCodes& codes, const ikd::Levels& levels, const IsoRenderParams& rp, std::uint32_t x0,
              std::uint32_t y0, Frame& f, IsoCounters& n) {
    constexpr int kTileWidth = packet_tile_width(L);
    ikd::BasicRayPacket<L> pk;
    std::array<std::size_t, L> at{};
    if (rp.rays.source != RaySource::Buffer) tile_camera_rays<L>(rp.camera, rp.rays.source, x0, y0, sp.width, sp.height, pk);
    for (int k = 0; k < L; ++k) {
        std::uint32_t x = x0 + static_cast<std::uint32_t>(k % kTileWidth), y = y0 + static_cast<std::uint32_t>(k / kTileWidth);
        if (x >= sp.width || y >= sp.height) continue;
        if (rp.rays.source == RaySource::Buffer) {
            Ray ray = pixel_ray(rp.camera, rp.rays, x, y, sp.width, sp.height);
            vec3 d = ray.direction;
            float len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
            pk.origin[k] = ray.origin;
            pk.direction[k] = vec3(d.x / len, d.y / len, d.z / len);
        }
        pk.t_min[k] = 0.0f;
        pk.t_max[k] = shared::sylva_inf();
        pk.active |= 1u << k;
        at[k] = std::size_t{y} * sp.width + x;
    }
    if (!ikd::same_signs(pk)) {  // single rays, as render_iso_cpu
        for (int k = 0; k < L; ++k) {
            if (!(pk.active >> k & 1u)) continue;
            shared::SylvaIsoRay r = shared::sylva_iso_trace(tw, gw, sp, hdr, pk.origin[k], pk.direction[k]);
            n.lane_steps += r.steps;  // a single ray is one active lane per step
            iso_store(r, at[k], f, n);
        }
        return;
    }
    // A constant border: each lane walks the shell cells before the grid alone (as the single
    // path does), the packet then walks the grid, and each lane the shell after it.
    const bool shell = sp.border_mode == SYLVA_ISO_BORDER_CONSTANT && sp.border_faces != 0u;
    std::array<vec4, L> rgba{};
    std::array<std::uint32_t, L> hits{};
    std::array<shared::SylvaShellIter, L> shells;  // set by sylva_shell_begin, read only with a border
    auto shell_phase = [&](int k) {
        shared::SylvaIsoRay r;
        r.rgba = rgba[k];
        r.cells = 0u;
        r.hits = 0u;
        shared::sylva_iso_shell_phase(r, shells[k], gw, sp, pk.direction[k]);
        rgba[k] = r.rgba;
        hits[k] += r.hits;
        n.cells += r.cells;
    };
    for (int k = 0; k < L && shell; ++k) {
        if (!(pk.active >> k & 1u)) continue;
        shared::sylva_shell_begin(shells[k], hdr, pk.origin[k], pk.direction[k], 0.0f, shared::sylva_inf(), sp.isos,
                                  sp.iso_count, sp.border, sp.border_faces);
        shell_phase(k);
    }
    ikd::BasicPacketIter<L> it({tw.data, tw.size}, {gw.data, gw.size}, hdr, pk, sp.isos, sp.iso_count, codes, levels);
    std::array<vec3, L> org{}, d{};
    for (int k = 0; k < L; ++k) {  // the cell-space ray (sylva_ray_to_grid's, as the single path)
        org[k] = it.lane_origin(k);
        d[k] = pk.direction[k] * hdr.inv_spacing;
        if (shell && !(rgba[k].w < sp.alpha_stop)) it.clip(k, -shared::sylva_inf());  // opaque in the shell
    }
    ikd::BasicPacketCell<L> c;
    while (it.next(c)) {
        for (int k = 0; k < L; ++k) {
            // Lanes done (opacity reached) take no more cells, as the single path stops; cells only
            // touched (length 0) are skipped, as there.
            if (!(c.mask >> k & 1u) || !(rgba[k].w < sp.alpha_stop) || !(c.t0[k] < c.t1[k])) continue;
            ++n.cells;
            rgba[k] = shared::sylva_iso_shade_cell(rgba[k], sp, c.cell, c.corners_lo, c.corners_hi, org[k], d[k],
                                                   hdr.inv_spacing, pk.direction[k], c.t0[k], c.t1[k], hits[k]);
            if (!(rgba[k].w < sp.alpha_stop)) it.clip(k, -shared::sylva_inf());
        }
    }
    for (int k = 0; k < L; ++k) {
        if (!(pk.active >> k & 1u)) continue;
        std::uint32_t shell_steps = 0;
        if (shell) {
            if (rgba[k].w < sp.alpha_stop) {  // the shell after the grid, unless the ray is done
                shared::sylva_shell_after(shells[k]);
                shell_phase(k);
            }
            shell_steps = shells[k].steps;
            n.lane_steps += shell_steps;  // a lane's shell walk is one active lane per step
            n.steps += shell_steps;
        }
        f.rgba[at[k]] = rgba[k];
        f.steps[at[k]] = it.status() == SYLVA_ITER_ERROR ? 0xFFFFFFFFu : it.steps() + shell_steps;
        n.hits += hits[k];
        n.errors += it.status() == SYLVA_ITER_ERROR ? 1u : 0u;
    }
    n.lane_steps += it.lane_steps();
    n.steps += it.steps();
}

}  // namespace detail

/// Rays a packet of render_iso_cpu_packets: 4 (2x2 pixels, one SSE group; Wald's packets), 8
/// (4x2 pixels, two SSE groups: fewer node visits a ray, fewer of its lanes active a visit; the
/// fastest on the README's volumes) or 16 (4x4 pixels).
enum class PacketLanes : std::uint32_t { Four = 4, Eight = 8, Sixteen = 16 };

namespace detail {

/// render_iso_cpu_packets' frame with packets of L rays.
template <int L, Executor X>
void iso_tiles(shared::Words tw, shared::Words gw, const shared::SylvaIsoParams& sp, const shared::SylvaIkdHeader& hdr,
               const ikd::IsoCodes& codes, const ikd::Levels& levels, const IsoRenderParams& p, X& exec, Frame& f,
               IsoTotals& totals) {
    constexpr std::uint32_t w = packet_tile_width(L), h = L / packet_tile_width(L);
    parallel_take(exec, 0, (p.height + h - 1) / h, 1, [&](std::size_t r0, std::size_t r1) {
        IsoCounters n;
        for (std::size_t r = r0; r < r1; ++r)
            for (std::uint32_t x = 0; x < p.width; x += w)
                iso_tile<L>(tw, gw, sp, hdr, codes, levels, p, x, static_cast<std::uint32_t>(h * r), f, n);
        totals.add(n);
    });
}

}  // namespace detail

/// render_iso_cpu with pixel packets of `lanes` rays traversing the tree together (Wald 4.3;
/// sylva/ikd/packet.hpp); p.walker must be IsoWalker::Tree. The image and the cell and hit
/// counts equal render_iso_cpu's bit for bit; steps count packet steps (each pixel of a tile
/// gets its packet's, plus its own shell cells under a constant border), Wald's Table I "SIMD"
/// column. Throws sylva::Error for a `lanes` other
/// than 4, 8 or 16.
template <Executor X>
Frame render_iso_cpu_packets(std::span<const std::uint32_t> words, const GridWords& grid, const IsoRenderParams& p,
                             X& exec, IsoCounters* counters = nullptr, PacketLanes lanes = PacketLanes::Eight) {
    if (p.walker != IsoWalker::Tree) throw Error("render: packets traverse the implicit kd-tree, not the DDA");
    if (lanes != PacketLanes::Four && lanes != PacketLanes::Eight && lanes != PacketLanes::Sixteen)
        throw Error("render: packets hold 4, 8 or 16 rays, not " + std::to_string(static_cast<std::uint32_t>(lanes)));
    check_iso_grid(grid);
    std::uint32_t faces = p.border ? iso_border_faces(iso_face_ranges(words, grid), p) : 0u;  // once a frame
    std::vector<std::uint32_t> params = iso_params(p, words.size(), grid.words.size(), grid.sampling, faces);
    shared::Words pw{params.data(), params.size()}, tw{words.data(), words.size()}, gw{grid.words.data(), grid.words.size()};
    shared::SylvaIsoParams sp = shared::sylva_iso_read_params(pw);
    shared::SylvaIkdHeader hdr = shared::sylva_iso_read_header(tw, sp);  // once a frame
    ikd::IsoCodes codes = ikd::iso_codes(sp.isos, sp.iso_count, hdr);                              // once a frame
    ikd::Levels levels = ikd::levels(words, hdr);                                                  // once a frame
    Frame f = detail::iso_frame(p);
    detail::IsoTotals totals;
    auto start = std::chrono::steady_clock::now();
    if (lanes == PacketLanes::Sixteen) detail::iso_tiles<16>(tw, gw, sp, hdr, codes, levels, p, exec, f, totals);
    else if (lanes == PacketLanes::Eight) detail::iso_tiles<8>(tw, gw, sp, hdr, codes, levels, p, exec, f, totals);
    else detail::iso_tiles<4>(tw, gw, sp, hdr, codes, levels, p, exec, f, totals);
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (counters) *counters = totals.get();
    return f;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_ISO_HPP
