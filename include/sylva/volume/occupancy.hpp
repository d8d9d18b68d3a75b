// sylva/volume/occupancy.hpp -- binary occupancy: which voxels matter under a classifier
// (Vidal et al. section 2.1: the volume V1 with 1 for non-empty voxels, 0 for empty ones).
//
// Occupancy is read a row at a time through the OccupancySource concept, so the stages that
// consume it (summed-volume tables, partial SVTs, the 8^3 local boxes of the binned kd-tree)
// can classify a volume on the fly without materialising V1, or read a materialised Occupancy.
//  * Occupancy             V1 itself, one byte (0 or 1) per voxel.
//  * ClassifiedVolume<C>   a Volume plus a classifier (volume/classify.hpp: DensityThreshold,
//                          TransferFunctionAlpha or any VoxelClassifier); uint8 and uint16
//                          volumes classify through a lookup table of every value.
//  * ClassifiedGrid<C>     a normalised DensityGrid plus a classifier.
// Densities are normalised exactly as volume::normalize does (grid.hpp), so classifying a Volume
// and classifying its DensityGrid give the same occupancy.
//
// Voxel boxes (VoxelBox) are half-open integer ranges [lo, hi) of voxel indices; under the cell
// convention of grid.hpp they cover the world box [lo * spacing, hi * spacing], so two boxes
// that share a face share it exactly.
#ifndef SYLVA_VOLUME_OCCUPANCY_HPP
#define SYLVA_VOLUME_OCCUPANCY_HPP

#include <algorithm>
#include <atomic>
#include <concepts>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/volume/classify.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

/// A half-open box of voxel indices [lo, hi). Empty when hi <= lo on some axis; the default
/// box is empty and absorbs any box it is extended by.
struct VoxelBox {
    uvec3 lo{0u};
    uvec3 hi{0u};

    [[nodiscard]] bool empty() const { return hi.x <= lo.x || hi.y <= lo.y || hi.z <= lo.z; }
    /// Number of voxels inside (0 when empty).
    [[nodiscard]] std::uint64_t volume() const {
        if (empty()) return 0;
        return std::uint64_t{hi.x - lo.x} * std::uint64_t{hi.y - lo.y} * std::uint64_t{hi.z - lo.z};
    }
    /// Edge length along `axis` in voxels (0 when empty there).
    [[nodiscard]] std::uint32_t extent(int axis) const { return hi[axis] > lo[axis] ? hi[axis] - lo[axis] : 0u; }
    /// Index of the longest axis (the first of equals).
    [[nodiscard]] int longest_axis() const {
        std::uint32_t x = extent(0), y = extent(1), z = extent(2);
        return (x >= y && x >= z) ? 0 : (y >= z ? 1 : 2);
    }
    [[nodiscard]] bool contains(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        return x >= lo.x && x < hi.x && y >= lo.y && y < hi.y && z >= lo.z && z < hi.z;
    }
    /// True when `b` is empty or lies inside this box.
    [[nodiscard]] bool contains(const VoxelBox& b) const {
        return b.empty() || (!empty() && glm::all(glm::lessThanEqual(lo, b.lo)) && glm::all(glm::lessThanEqual(b.hi, hi)));
    }
    /// Grows this box to hold `b` (an empty `b` changes nothing).
    void extend(const VoxelBox& b) {
        if (b.empty()) return;
        if (empty()) {
            *this = b;
            return;
        }
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    /// World box under the cell convention: [origin + lo * spacing, origin + hi * spacing].
    [[nodiscard]] Aabb world(vec3 spacing, vec3 origin = vec3(0.0f)) const {
        if (empty()) return Aabb{};
        return Aabb{origin + vec3(lo) * spacing, origin + vec3(hi) * spacing};
    }
    friend bool operator==(const VoxelBox& a, const VoxelBox& b) {
        return (a.empty() && b.empty()) || (a.lo == b.lo && a.hi == b.hi);
    }
};

/// The overlap of two boxes (empty when they do not overlap).
inline VoxelBox intersect(const VoxelBox& a, const VoxelBox& b) {
    VoxelBox r{glm::max(a.lo, b.lo), glm::min(a.hi, b.hi)};
    return r.empty() ? VoxelBox{} : r;
}

/// The box of a whole grid: [0, dims).
inline VoxelBox full_box(Dims dims) { return VoxelBox{uvec3(0u), uvec3(dims)}; }

/// Anything that reports occupancy a row at a time: `row(x0, x1, y, z, out)` writes 0 or 1 for
/// voxels (x0 .. x1-1, y, z) to out[0 .. x1-x0-1]; `dims` and `spacing` describe the grid.
template <class S>
concept OccupancySource = requires(const S& s, std::uint32_t c, std::uint8_t* out) {
    { s.dims } -> std::convertible_to<Dims>;
    { s.spacing } -> std::convertible_to<vec3>;
    s.row(c, c, c, c, out);
};

namespace detail {

/// Number of ones in `n` bytes that are each 0 or 1 (eight at a time: the byte sum of a 64-bit
/// word is the top byte of word * 0x0101010101010101).
inline std::uint32_t count_ones(const std::uint8_t* p, std::size_t n) {
    std::uint32_t c = 0;
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        std::uint64_t w;
        std::memcpy(&w, p + i, 8);
        c += static_cast<std::uint32_t>((w * 0x0101010101010101ull) >> 56);
    }
    for (; i < n; ++i) c += p[i];
    return c;
}

}  // namespace detail

/// V1: one byte per voxel, 1 = occupied (x fastest, as the grid).
struct Occupancy {
    Dims dims{0};
    vec3 spacing{1.0f};
    std::vector<std::uint8_t> voxels;

    [[nodiscard]] bool at(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        return voxels[voxel_index(dims, x, y, z)] != 0;
    }
    void row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, std::uint8_t* out) const {
        std::copy_n(voxels.data() + voxel_index(dims, x0, y, z), x1 - x0, out);
    }
    /// Number of occupied voxels.
    [[nodiscard]] std::uint64_t count() const {
        std::uint64_t n = 0;
        for (std::size_t i = 0; i < voxels.size(); i += 1u << 20)
            n += detail::count_ones(voxels.data() + i, std::min<std::size_t>(1u << 20, voxels.size() - i));
        return n;
    }
};

namespace detail {

/// Normalised density of raw value x, computed exactly as volume::normalize does:
/// clamp((x - lo) / span, 0, 1), 0 for an empty range (span <= 0).
inline float normalised(float x, float lo, float span) {
    return span > 0.0f ? glm::clamp((x - lo) / span, 0.0f, 1.0f) : 0.0f;
}

/// range_hi - range_lo of a volume (normalised reads 0 everywhere when it is <= 0).
inline float value_span(const Volume& v) { return v.range_hi - v.range_lo; }

/// One byte per possible raw value of an integer volume: the classifier's verdict on it.
template <class C>
std::vector<std::uint8_t> value_table(const Volume& v, const C& classify) {
    std::size_t values = v.type == ScalarType::U8 ? 256u : 65536u;
    std::vector<std::uint8_t> lut(values);
    float span = value_span(v);
    for (std::size_t i = 0; i < values; ++i)
        lut[i] = classify(normalised(static_cast<float>(i), v.range_lo, span)) ? 1u : 0u;
    return lut;
}

}  // namespace detail

/// A Volume classified on the fly (the source of a rebuild after a transfer-function change).
/// The volume must outlive it. Rows of a float32 volume throw sylva::Error naming the voxel
/// when it holds NaN or infinity (as volume::normalize does).
template <VoxelClassifier C>
class ClassifiedVolume {
public:
    ClassifiedVolume(const Volume& v, C classify)
        : dims(v.dims), spacing(v.spacing), volume_(&v), classify_(std::move(classify)) {
        std::size_t n = voxel_count(v.dims, scalar_bytes(v.type));
        if (v.bytes.size() != n * scalar_bytes(v.type))
            throw Error("occupancy: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) +
                        " " + scalar_name(v.type) + " voxels");
        if (v.type != ScalarType::F32) lut_ = detail::value_table(v, classify_);
        span_ = detail::value_span(v);
    }

    Dims dims;
    vec3 spacing;

    void row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, std::uint8_t* out) const {
        std::size_t at = voxel_index(dims, x0, y, z), n = x1 - x0;
        switch (volume_->type) {
            case ScalarType::U8: {  // locals: `out` may alias anything, keep the loop free of reloads
                const std::uint8_t* __restrict lut = lut_.data();
                const auto* __restrict p = reinterpret_cast<const std::uint8_t*>(volume_->bytes.data()) + at;
                for (std::size_t i = 0; i < n; ++i) out[i] = lut[p[i]];
                break;
            }
            case ScalarType::U16: {
                const std::uint8_t* __restrict lut = lut_.data();
                const std::uint16_t* __restrict p = volume_->view<std::uint16_t>().data.data() + at;
                for (std::size_t i = 0; i < n; ++i) out[i] = lut[p[i]];
                break;
            }
            default: float_row(at, n, out); break;
        }
    }

private:
    void float_row(std::size_t at, std::size_t n, std::uint8_t* out) const {
        auto g = volume_->view<float>();
        for (std::size_t i = 0; i < n; ++i) {
            float x = g.data[at + i];
            if (!std::isfinite(x)) throw Error("occupancy: voxel " + std::to_string(at + i) + " is not a finite number");
            out[i] = classify_(detail::normalised(x, volume_->range_lo, span_)) ? 1u : 0u;
        }
    }

    const Volume* volume_;
    C classify_;
    std::vector<std::uint8_t> lut_;
    float span_ = 0.0f;
};

/// A normalised DensityGrid classified on the fly; the grid must outlive it. NaN densities
/// throw sylva::Error naming the voxel.
template <VoxelClassifier C>
class ClassifiedGrid {
public:
    ClassifiedGrid(const DensityGrid& g, C classify) : dims(g.dims), spacing(g.spacing), grid_(&g), classify_(std::move(classify)) {
        if (g.values.size() != voxel_count(g.dims))
            throw Error("occupancy: " + std::to_string(g.values.size()) + " densities do not match the grid's dimensions");
    }

    Dims dims;
    vec3 spacing;

    void row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, std::uint8_t* out) const {
        std::size_t at = voxel_index(dims, x0, y, z);
        for (std::size_t i = 0, n = x1 - x0; i < n; ++i) {
            float d = grid_->values[at + i];
            if (std::isnan(d)) throw Error("occupancy: density of voxel " + std::to_string(at + i) + " is NaN");
            out[i] = classify_(d) ? 1u : 0u;
        }
    }

private:
    const DensityGrid* grid_;
    C classify_;
};

/// Convenience: the occupancy source of `v` under `classify`.
template <VoxelClassifier C>
ClassifiedVolume<C> classified(const Volume& v, C classify) {
    return ClassifiedVolume<C>(v, std::move(classify));
}
template <VoxelClassifier C>
ClassifiedGrid<C> classified(const DensityGrid& g, C classify) {
    return ClassifiedGrid<C>(g, std::move(classify));
}

namespace detail {

/// Runs f(y, z, row_buffer) over every row of the grid in parallel; rows are filled by `src`.
template <OccupancySource S, Executor X, class F>
void for_each_row(const S& src, X& exec, F&& f) {
    Dims d = src.dims;
    std::size_t rows = std::size_t{d.y} * d.z;
    std::size_t grain = std::max<std::size_t>(1, (std::size_t{1} << 16) / d.x);
    exec.parallel_for(0, rows, grain, [&](std::size_t lo, std::size_t hi) {
        std::vector<std::uint8_t> buf(d.x);
        for (std::size_t r = lo; r < hi; ++r) {
            auto y = static_cast<std::uint32_t>(r % d.y), z = static_cast<std::uint32_t>(r / d.y);
            src.row(0, d.x, y, z, buf.data());
            f(y, z, buf.data());
        }
    });
}

/// One line of a box dilation: dst[i] = 1 when src has an occupied voxel within `radius` of i.
inline void dilate_line(const std::uint8_t* src, std::uint8_t* dst, std::size_t stride, std::uint32_t n,
                        std::uint32_t radius) {
    std::int64_t last = -1;  // nearest occupied index at or before i
    for (std::uint32_t i = 0; i < n; ++i) {
        if (src[i * stride]) last = i;
        dst[i * stride] = (last >= 0 && i - last <= radius) ? 1u : 0u;
    }
    std::int64_t next = -1;  // nearest occupied index at or after i
    for (std::uint32_t i = n; i-- > 0;) {
        if (src[i * stride]) next = i;
        if (next >= 0 && next - i <= radius) dst[i * stride] = 1u;
    }
}

}  // namespace detail

/// Materialises the occupancy of any source (Vidal section 2.1, V1), in parallel over rows.
template <OccupancySource S, Executor X>
Occupancy classify(const S& src, X& exec) {
    Occupancy occ{src.dims, src.spacing, std::vector<std::uint8_t>(voxel_count(src.dims))};
    Dims d = src.dims;
    detail::for_each_row(src, exec, [&](std::uint32_t y, std::uint32_t z, const std::uint8_t* row) {
        std::copy_n(row, d.x, occ.voxels.data() + voxel_index(d, 0, y, z));
    });
    return occ;
}

/// Counts the occupied voxels of a source: one streaming pass (read + classify), the yardstick
/// the kd-tree builds are measured against.
template <OccupancySource S, Executor X>
std::uint64_t count_occupied(const S& src, X& exec) {
    std::atomic<std::uint64_t> total{0};
    Dims d = src.dims;
    std::size_t rows = std::size_t{d.y} * d.z;
    std::size_t grain = std::max<std::size_t>(1, (std::size_t{1} << 16) / d.x);
    exec.parallel_for(0, rows, grain, [&](std::size_t lo, std::size_t hi) {
        std::vector<std::uint8_t> buf(d.x);
        std::uint64_t n = 0;
        for (std::size_t r = lo; r < hi; ++r) {
            src.row(0, d.x, static_cast<std::uint32_t>(r % d.y), static_cast<std::uint32_t>(r / d.y), buf.data());
            n += detail::count_ones(buf.data(), buf.size());
        }
        total.fetch_add(n);
    });
    return total.load();
}

/// Grows the occupancy by `radius` voxels along every axis (a box dilation, separable). A
/// renderer that reconstructs trilinearly between voxel centres needs radius 1: a sample in
/// the cell of an empty voxel can still see an occupied neighbour, so leaves built on the
/// dilated occupancy hold every sample that can be non-zero.
template <Executor X>
Occupancy dilate(const Occupancy& occ, std::uint32_t radius, X& exec) {
    Occupancy out = occ;
    if (radius == 0) return out;
    Dims d = occ.dims;
    std::vector<std::uint8_t> tmp(out.voxels.size());
    for (int axis = 0; axis < 3; ++axis) {
        std::size_t stride = axis == 0 ? 1 : (axis == 1 ? std::size_t{d.x} : std::size_t{d.x} * d.y);
        std::uint32_t n = d[axis];
        std::size_t lines = out.voxels.size() / n;
        exec.parallel_for(0, lines, 256, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t l = lo; l < hi; ++l) {
                std::size_t base = axis == 0 ? l * n : (axis == 1 ? (l % d.x) + (l / d.x) * stride * n : l);
                detail::dilate_line(out.voxels.data() + base, tmp.data() + base, stride, n, radius);
            }
        });
        out.voxels.swap(tmp);
    }
    return out;
}

/// The tight box of the occupied voxels of `region`, found by shrinking each face with a
/// binary search (Vidal et al. eq. 3, accelerated as in Zellmann et al. Fig. 1).
/// `count(box)` returns the number of occupied voxels of any box inside `region`; an empty
/// region or one without occupied voxels gives the empty box. 6 * log2(extent) + 1 queries.
template <class CountFn>
VoxelBox shrink_to_occupied(VoxelBox r, CountFn&& count) {
    if (r.empty() || count(r) == 0) return VoxelBox{};
    for (int a = 0; a < 3; ++a) {
        std::uint32_t lo = r.lo[a], hi = r.hi[a] - 1;  // smallest occupied index along a
        while (lo < hi) {
            std::uint32_t mid = lo + (hi - lo) / 2;
            VoxelBox s = r;
            s.hi[a] = mid + 1;
            if (count(s) > 0) hi = mid; else lo = mid + 1;
        }
        r.lo[a] = lo;
        lo = r.lo[a];
        hi = r.hi[a] - 1;  // largest occupied index along a
        while (lo < hi) {
            std::uint32_t mid = lo + (hi - lo + 1) / 2;
            VoxelBox s = r;
            s.lo[a] = mid;
            if (count(s) > 0) lo = mid; else hi = mid - 1;
        }
        r.hi[a] = lo + 1;
    }
    return r;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_OCCUPANCY_HPP
