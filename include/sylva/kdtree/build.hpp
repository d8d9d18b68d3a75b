// sylva/kdtree/build.hpp -- top-down empty-space kd-tree construction (Vidal et al. section 2.1)
// over a full summed-volume table: the serial builder, and the driver every builder shares.
//
// Starting from the tight box of all occupied voxels, each node is split along the longest
// axis of its box at the candidate plane that minimises C = BV(lower) + BV(upper), the volumes
// of the tight boxes of the occupied voxels on either side (Vidal eq. 1); equivalently, the
// plane that removes the most empty space (eq. 2), ties going to the plane nearest the middle.
// A node becomes a leaf at a halting
// criterion (section 2.1.4): its box is small, no plane removes enough empty space, or it is
// at the maximum depth. Both children of a split are non-empty and strictly smaller (a tight
// box has occupied voxels on both faces of every axis, and planes lie strictly inside it), so
// every build terminates.
//
// The driver grows the tree one level at a time, deciding the nodes of a level in parallel on
// the executor; how the two tight boxes of each candidate plane are found is the builder's
// "splitter": the full SVT here, partial SVTs in build_parallel.hpp, the Morton-sorted 8^3
// local boxes in build_binned.hpp. Decisions do not depend on the thread count, so a build
// gives the same tree on 1 or N threads.
#ifndef SYLVA_KDTREE_BUILD_HPP
#define SYLVA_KDTREE_BUILD_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/kdtree/tree.hpp"
#include "sylva/shared/kd_layout.h"
#include "sylva/volume/occupancy.hpp"
#include "sylva/volume/svt.hpp"

namespace sylva::kdtree {

/// Where candidate split planes are placed along the split axis.
enum class Planes {
    Step,    ///< every Δl voxels from the box's lower face (Vidal section 2.1.3)
    Binned,  ///< a fixed number of bins, planes snapped to a voxel raster (Zellmann section 4.3)
};

/// Builder settings. The defaults are Vidal et al.'s ("shallow" trees in Zellmann et al.).
struct Config {
    /// Halting 1: a node whose box holds fewer voxels than this fraction of the whole grid is a
    /// leaf (Vidal section 2.1.4: 10 % of the original volume).
    double min_volume_fraction = 0.10;
    /// Halting 1, absolute: a node whose box holds fewer voxels than this is a leaf (Zellmann
    /// section 5, deep trees: 8^3 = 512; 0 = off).
    std::uint64_t min_volume_voxels = 0;
    /// Halting 2: a node is split only when the best plane removes at least this fraction of
    /// its box as empty space, EV / BV(n) (Vidal section 2.1.4: 5 %).
    double min_removed_fraction = 0.05;
    /// Halting 3: nodes at this depth are leaves (Vidal section 2.1.4: 10, "seldom used");
    /// clamped to SYLVA_KD_DEPTH_CAP.
    std::uint32_t max_depth = 10;
    /// Candidate plane placement for the SVT builders (build_binned always bins).
    Planes planes = Planes::Step;
    /// Planes::Step: distance Δl between candidate planes in voxels (Vidal section 2.1.3: 4 for
    /// 256^3 and 8 for 512^3 grids); 0 = ceil(longest grid dimension / 64), which gives those
    /// values and at most 64 planes a node. Boxes not longer than Δl use every voxel plane.
    std::uint32_t plane_step = 0;
    /// Planes::Binned: candidate planes a node, bins - 1 of them (Zellmann section 5: 4 bins).
    std::uint32_t bins = 4;
    /// Planes::Binned: planes fall on multiples of this many voxels (Zellmann section 4.3: 8).
    std::uint32_t raster = 8;

    /// Vidal et al.'s halting criteria: few, large leaves ("shallow" trees in Zellmann Table 1).
    static Config shallow() { return Config{}; }
    /// Zellmann et al.'s deep trees (section 5): split down to 8^3-voxel boxes, no other limit
    /// than the depth cap.
    static Config deep() {
        Config c;
        c.min_volume_fraction = 0.0;
        c.min_volume_voxels = 512;
        c.min_removed_fraction = 0.0;
        c.max_depth = SYLVA_KD_DEPTH_CAP;
        return c;
    }
    /// The same with binned candidate planes.
    [[nodiscard]] Config binned(std::uint32_t bin_count = 4) const {
        Config c = *this;
        c.planes = Planes::Binned;
        c.bins = bin_count;
        return c;
    }
};

/// The two tight boxes a candidate plane produces.
struct Split {
    VoxelBox lower;
    VoxelBox upper;
};

/// What a builder plugs into the driver: the tight box of everything, the occupied voxel
/// count, and the two tight boxes of each candidate plane of a node.
template <class S>
concept Splitter = requires(const S& s, const VoxelBox& box, int axis, std::span<const std::uint32_t> planes,
                            std::span<Split> out) {
    { s.root_box() } -> std::same_as<VoxelBox>;
    { s.occupied() } -> std::convertible_to<std::uint64_t>;
    s.evaluate(box, axis, planes, out);
};

namespace detail {

inline void check_config(const Config& c) {
    auto fraction = [](double f) { return std::isfinite(f) && f >= 0.0 && f <= 1.0; };
    if (!fraction(c.min_volume_fraction) || !fraction(c.min_removed_fraction))
        throw Error("kdtree: halting fractions must be finite numbers in [0, 1]");
    if (c.planes == Planes::Binned && (c.bins < 2 || c.raster < 1))
        throw Error("kdtree: binned planes need at least 2 bins and a raster of at least 1 voxel");
}

/// Vidal's Δl: the configured step, or ceil(longest dimension / 64).
inline std::uint32_t plane_step(const Config& c, volume::Dims dims) {
    if (c.plane_step) return c.plane_step;
    std::uint32_t longest = std::max({dims.x, dims.y, dims.z});
    return std::max<std::uint32_t>(1, (longest + 63) / 64);
}

/// Planes every `step` voxels from lo, strictly inside (lo, hi); every voxel plane when the box
/// is not longer than one step.
inline void step_planes(std::uint32_t lo, std::uint32_t hi, std::uint32_t step, std::vector<std::uint32_t>& out) {
    if (hi - lo <= step) step = 1;
    for (std::uint64_t p = std::uint64_t{lo} + step; p < hi; p += step) out.push_back(static_cast<std::uint32_t>(p));
}

/// bins - 1 planes at lo + k (hi - lo) / bins, each rounded to the nearest multiple of the
/// raster, strictly inside (lo, hi), without repeats; when rounding leaves none but a raster
/// line lies inside, the raster line nearest the middle.
inline void binned_planes(std::uint32_t lo, std::uint32_t hi, std::uint32_t bins, std::uint32_t raster,
                          std::vector<std::uint32_t>& out) {
    std::uint64_t first = (std::uint64_t{lo} / raster + 1) * raster, last = (std::uint64_t{hi} - 1) / raster * raster;
    if (first > last) return;
    for (std::uint32_t k = 1; k < bins; ++k) {
        double target = lo + (double(hi) - double(lo)) * k / bins;
        auto p = static_cast<std::uint64_t>(std::floor(target / raster + 0.5)) * raster;
        if (p > lo && p < hi && (out.empty() || p > out.back())) out.push_back(static_cast<std::uint32_t>(p));
    }
    if (!out.empty()) return;
    double mid = (double(lo) + double(hi)) * 0.5;
    auto p = static_cast<std::uint64_t>(std::floor(mid / raster + 0.5)) * raster;
    out.push_back(static_cast<std::uint32_t>(std::clamp(p, first, last)));
}

/// The candidate planes of `box` along `axis`, ascending, strictly inside the box.
inline void candidate_planes(const VoxelBox& box, int axis, const Config& c, volume::Dims dims,
                             std::vector<std::uint32_t>& out) {
    out.clear();
    if (c.planes == Planes::Step) step_planes(box.lo[axis], box.hi[axis], plane_step(c, dims), out);
    else binned_planes(box.lo[axis], box.hi[axis], c.bins, c.raster, out);
}

/// What the driver decided for one node.
struct Decision {
    bool split = false;
    std::uint8_t axis = kLeaf;
    std::uint32_t plane = 0;
    Split children;
};

/// Limits derived from the config and the grid.
struct Limits {
    double min_volume = 0.0;
    std::uint32_t max_depth = 0;
};

/// Applies the halting criteria to node `n` and, where it splits, picks the cheapest plane
/// (Vidal eqs. 1-2). Among planes of equal cost the one nearest the middle of the box wins (the
/// first of two equally near): where no plane removes empty space, as inside dense regions of
/// deep trees, splits stay balanced instead of peeling Δl-thin slabs off one side.
/// Scratch vectors are the caller's.
template <Splitter S>
Decision decide(const Node& n, const S& splitter, const Config& c, const Limits& lim, volume::Dims dims,
                std::vector<std::uint32_t>& planes, std::vector<Split>& evals) {
    Decision d;
    double vol = static_cast<double>(n.box.volume());
    if (n.depth >= lim.max_depth || vol < lim.min_volume) return d;
    int axis = n.box.longest_axis();
    candidate_planes(n.box, axis, c, dims, planes);
    if (planes.empty()) return d;
    evals.assign(planes.size(), Split{});
    splitter.evaluate(n.box, axis, std::span<const std::uint32_t>(planes), std::span<Split>(evals));
    std::size_t best = 0;
    std::uint64_t best_cost = ~std::uint64_t{0}, best_offset = 0;
    std::uint64_t middle2 = std::uint64_t{n.box.lo[axis]} + n.box.hi[axis];  // twice the middle
    for (std::size_t k = 0; k < evals.size(); ++k) {
        std::uint64_t cost = evals[k].lower.volume() + evals[k].upper.volume();
        std::uint64_t p2 = 2 * std::uint64_t{planes[k]}, offset = p2 > middle2 ? p2 - middle2 : middle2 - p2;
        if (cost < best_cost || (cost == best_cost && offset < best_offset)) best_cost = cost, best = k, best_offset = offset;
    }
    double removed = vol - static_cast<double>(best_cost);
    if (removed < c.min_removed_fraction * vol) return d;
    if (evals[best].lower.empty() || evals[best].upper.empty())
        throw Error("kdtree: splitter returned an empty child for a tight box (inconsistent occupancy)");
    d.split = true;
    d.axis = static_cast<std::uint8_t>(axis);
    d.plane = planes[best];
    d.children = evals[best];
    return d;
}

/// Numbers the leaves breadth first and fills the statistics of a grown tree.
inline void finish(Tree& t) {
    t.leaves.clear();
    t.stats.leaf_volume = 0;
    t.stats.max_depth = 0;
    for (std::uint32_t i = 0; i < t.nodes.size(); ++i) {
        Node& n = t.nodes[i];
        t.stats.max_depth = std::max<std::uint32_t>(t.stats.max_depth, n.depth);
        if (!n.is_leaf()) continue;
        n.leaf = static_cast<std::uint32_t>(t.leaves.size());
        t.leaves.push_back(i);
        t.stats.leaf_volume += n.box.volume();
    }
    t.stats.nodes = t.nodes.size();
    t.stats.leaves = t.leaves.size();
}

/// Appends the children of every split node of `level` and returns the next level.
inline std::vector<std::uint32_t> apply(Tree& t, const std::vector<std::uint32_t>& level,
                                        const std::vector<Decision>& dec) {
    std::vector<std::uint32_t> next;
    for (std::size_t i = 0; i < level.size(); ++i) {
        if (!dec[i].split) continue;
        auto first = static_cast<std::uint32_t>(t.nodes.size());
        std::uint8_t depth = static_cast<std::uint8_t>(t.nodes[level[i]].depth + 1);
        Node& n = t.nodes[level[i]];
        n.axis = dec[i].axis;
        n.plane = dec[i].plane;
        n.first_child = first;
        Node lower, upper;
        lower.box = dec[i].children.lower;
        upper.box = dec[i].children.upper;
        lower.depth = upper.depth = depth;
        t.nodes.push_back(lower);
        t.nodes.push_back(upper);
        next.push_back(first);
        next.push_back(first + 1);
    }
    return next;
}

inline double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace detail

/// Grows a tree over a grid of `dims` voxels with `splitter`, level by level, deciding the
/// nodes of a level in parallel. Fills stats (occupancy_ms stays as the caller sets it).
template <Splitter S, Executor X>
Tree grow(const S& splitter, const Config& cfg, X& exec, volume::Dims dims, vec3 spacing) {
    detail::check_config(cfg);
    auto t0 = std::chrono::steady_clock::now();
    Tree t;
    t.dims = dims;
    t.spacing = spacing;
    t.stats.voxels = volume::voxel_count(dims);
    t.stats.occupied = splitter.occupied();
    VoxelBox root = splitter.root_box();
    if (!root.empty()) {
        detail::Limits lim{std::max(cfg.min_volume_fraction * static_cast<double>(t.stats.voxels),
                                    static_cast<double>(cfg.min_volume_voxels)),
                           std::min<std::uint32_t>(cfg.max_depth, SYLVA_KD_DEPTH_CAP)};
        t.nodes.push_back(Node{root});
        std::vector<std::uint32_t> level{0};
        while (!level.empty()) {
            std::vector<detail::Decision> dec(level.size());
            exec.parallel_for(0, level.size(), 1, [&](std::size_t lo, std::size_t hi) {
                std::vector<std::uint32_t> planes;
                std::vector<Split> evals;
                for (std::size_t i = lo; i < hi; ++i)
                    dec[i] = detail::decide(t.nodes[level[i]], splitter, cfg, lim, dims, planes, evals);
            });
            level = detail::apply(t, level, dec);
        }
    }
    detail::finish(t);
    t.stats.split_ms = detail::ms_since(t0);
    return t;
}

/// The splitter of the serial builder: tight boxes from a full summed-volume table.
template <std::unsigned_integral C>
struct SvtSplitter {
    const volume::SummedVolumeTable<C>* svt;

    [[nodiscard]] VoxelBox root_box() const { return svt->tight_box(volume::full_box(svt->dims())); }
    [[nodiscard]] std::uint64_t occupied() const { return svt->total(); }
    void evaluate(const VoxelBox& box, int axis, std::span<const std::uint32_t> planes, std::span<Split> out) const {
        for (std::size_t k = 0; k < planes.size(); ++k) {
            VoxelBox lower = box, upper = box;
            lower.hi[axis] = planes[k];
            upper.lo[axis] = planes[k];
            out[k] = Split{svt->tight_box(lower), svt->tight_box(upper)};
        }
    }
};

/// Vidal et al.'s serial builder over a full summed-volume table.
template <std::unsigned_integral C>
Tree build(const volume::SummedVolumeTable<C>& svt, const Config& cfg = {}) {
    SerialExecutor serial;
    return grow(SvtSplitter<C>{&svt}, cfg, serial, svt.dims(), svt.spacing());
}

/// The same over a table of either width.
inline Tree build(const volume::AnySvt& svt, const Config& cfg = {}) {
    return std::visit([&](const auto& s) { return build(s, cfg); }, svt);
}

/// Classifies `src`, builds its full summed-volume table and the tree (Vidal et al. section
/// 2.3, steps 1-3); stats.occupancy_ms is the table's time, stats.split_ms the splitting's.
template <volume::OccupancySource Src>
Tree build_vidal(const Src& src, const Config& cfg = {}) {
    auto t0 = std::chrono::steady_clock::now();
    volume::AnySvt svt = volume::make_svt(src);
    double svt_ms = detail::ms_since(t0);
    Tree t = build(svt, cfg);
    t.stats.occupancy_ms = svt_ms;
    return t;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_BUILD_HPP
