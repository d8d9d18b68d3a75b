// sylva/kdtree/rebuild.hpp -- kd-tree rebuilds after a transfer-function change (Zellmann et
// al.: "full reconstruction, e.g. due to changes to the alpha transfer function during
// rendering"; section 4.1 allocates the partial SVTs once per volume).
//
//   sylva::ThreadPool pool;
//   sylva::kdtree::Rebuilder r(volume, sylva::kdtree::Config::deep().binned(), pool);
//   sylva::kdtree::Tree t = r.rebuild(tf);           // TF alpha > 0 decides occupancy
//   t = r.rebuild(sylva::volume::DensityThreshold{0.3f});  // any VoxelClassifier
//   double ms = r.timings().total_ms();
//
// A Rebuilder keeps what does not depend on the classification and reuses it every rebuild:
//  * the per-value table of a uint8 / uint16 volume (256 / 65536 entries, refilled in place),
//  * binned trees (Config::planes == Planes::Binned, Zellmann section 4.3): the Morton order of
//    the 8^3 blocks (kdtree::BlockOrder, computed once), the dense block words and the
//    local-box arrays (cleared, capacity kept), so the boxes come out sorted without a sort;
//    and the value range of every block (kdtree::BlockValues, one pass at construction): a
//    rebuild decides each block from its range first (block_verdicts: no occupied value in
//    the range -> empty, every value occupied -> full) and reads only the others, which in
//    sparse volumes are few;
//  * every other tree (Planes::Step, Vidal's planes): the 32^3 partial SVTs of Zellmann's
//    multi-core builder (section 4.1), reassigned in place; the tree equals Vidal's serial one.
// rebuild(c) returns exactly the tree the fresh builders give for the same classifier:
// build_binned(classified(v, c), cfg, exec) or build_parallel(classified(v, c), cfg, exec)
// (nodes, leaves and statistics; only the timings differ).
//
// A classifier that accepts no voxel, such as a transfer function without an opaque entry,
// gives a Tree without nodes or leaves (stats.occupied == 0), as the fresh builders do: it
// encodes to a header-only word array whose iterator yields nothing. An all-opaque transfer
// function gives a tree whose root is the whole grid.
#ifndef SYLVA_KDTREE_REBUILD_HPP
#define SYLVA_KDTREE_REBUILD_HPP

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/build.hpp"
#include "sylva/kdtree/build_binned.hpp"
#include "sylva/kdtree/build_parallel.hpp"
#include "sylva/kdtree/gpu_local_boxes.hpp"
#include "sylva/kdtree/local_boxes.hpp"
#include "sylva/volume/classify.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"
#include "sylva/volume/partial_svt.hpp"
#include "sylva/volume/transfer_function.hpp"

namespace sylva::kdtree {

/// Where the time of one rebuild went (milliseconds).
struct RebuildTimings {
    double classify_ms = 0.0;   ///< the per-value table of an integer volume, binned: block verdicts
    double occupancy_ms = 0.0;  ///< local boxes or partial SVTs: reading and classifying the volume
    double split_ms = 0.0;      ///< node splitting
    std::size_t blocks_read = 0;  ///< binned: 8^3 blocks whose voxels were read (the others were decided by their value range)
    [[nodiscard]] double total_ms() const { return classify_ms + occupancy_ms + split_ms; }
};

namespace detail {

/// The rows of an integer volume classified through a per-value table the caller keeps
/// (volume::ClassifiedVolume without its own table).
struct TableRows {
    volume::Dims dims;
    vec3 spacing;
    const std::byte* data;
    std::uint32_t source;  ///< SYLVA_KD_BOX_SOURCE_U8 or _U16
    const std::uint8_t* table;

    void row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, std::uint8_t* out) const {
        std::size_t at = volume::voxel_index(dims, x0, y, z), n = x1 - x0;
        const std::uint8_t* __restrict lut = table;
        if (source == SYLVA_KD_BOX_SOURCE_U8) {
            const auto* __restrict p = reinterpret_cast<const std::uint8_t*>(data) + at;
            for (std::size_t i = 0; i < n; ++i) out[i] = lut[p[i]];
        } else {
            const auto* __restrict p = reinterpret_cast<const std::uint16_t*>(data) + at;
            for (std::size_t i = 0; i < n; ++i) out[i] = lut[p[i]];
        }
    }
};

}  // namespace detail

/// Rebuilds the kd-tree of one volume or density grid under changing classifiers, reusing
/// every allocation that does not depend on them (see the top of this header). The volume or
/// grid must outlive the Rebuilder, and so must the executor. Not thread safe: one rebuild at
/// a time.
template <Executor X>
class Rebuilder {
public:
    /// A volume of any scalar type; throws sylva::Error when its bytes do not match its
    /// dimensions, or for a bad config.
    Rebuilder(const volume::Volume& v, const Config& cfg, X& exec)
        : source_(BoxSource::of(v)), volume_(&v), exec_(&exec) {
        set_config(cfg);
    }
    /// A normalised density grid (classified as it is, as volume::ClassifiedGrid does).
    Rebuilder(const volume::DensityGrid& g, const Config& cfg, X& exec)
        : source_(BoxSource::of(g)), grid_(&g), exec_(&exec) {
        set_config(cfg);
    }

    /// The tree under `tf`: voxels whose alpha exceeds `min_alpha` (volume::TransferFunctionAlpha).
    Tree rebuild(const volume::TransferFunction& tf, float min_alpha = 0.0f) {
        return rebuild(volume::TransferFunctionAlpha(tf, min_alpha));
    }

    /// The tree under any classifier. Bad float voxels throw sylva::Error (as the sources do).
    template <volume::VoxelClassifier C>
    Tree rebuild(const C& classify) {
        timings_ = RebuildTimings{};
        auto t0 = std::chrono::steady_clock::now();
        bool integer = volume_ && source_.source != SYLVA_KD_BOX_SOURCE_F32;
        if (integer) value_table(source_, classify, table_);
        if (cfg_.planes == Planes::Binned) {
            block_verdicts(source_, values_, classify, table_, scratch_, verdicts_);
            timings_.blocks_read = static_cast<std::size_t>(std::count(verdicts_.begin(), verdicts_.end(), kBlockRead));
        }
        timings_.classify_ms = detail::ms_since(t0);
        if (integer)
            return build_from(detail::TableRows{source_.dims, source_.spacing, source_.bytes.data(), source_.source,
                                                table_.data()});
        if (volume_) return build_from(volume::ClassifiedVolume<C>(*volume_, classify));
        return build_from(volume::ClassifiedGrid<C>(*grid_, classify));
    }

    /// The config of the next rebuilds (storage is kept; switching to binned planes computes
    /// the block order once). Throws sylva::Error for a bad config.
    void set_config(const Config& cfg) {
        detail::check_config(cfg);
        if (cfg.planes == Planes::Binned && (cfg.raster == 0 || cfg.raster % LocalBoxes::block != 0))
            throw Error("kdtree: the binned builder's raster must be a multiple of the 8-voxel block");
        cfg_ = cfg;
        if (cfg_.planes == Planes::Binned && order_.size() == 0) {
            auto t0 = std::chrono::steady_clock::now();
            order_ = BlockOrder::of(source_.dims);
            block_values(source_, *exec_, values_);
            prepare_ms_ = detail::ms_since(t0);
        }
    }
    [[nodiscard]] const Config& config() const { return cfg_; }
    /// Phases of the last rebuild.
    [[nodiscard]] const RebuildTimings& timings() const { return timings_; }
    /// The classification-independent preparation of binned rebuilds (block order and value
    /// ranges), milliseconds; 0 before the first binned config.
    [[nodiscard]] double prepare_ms() const { return prepare_ms_; }
    /// Binned trees: the local boxes of the last rebuild.
    [[nodiscard]] const LocalBoxes& local_boxes() const { return boxes_; }
    /// What the device pass reads (kdtree/gpu_local_boxes.hpp, vulkan/kd_build.hpp).
    [[nodiscard]] const BoxSource& source() const { return source_; }

private:
    template <volume::OccupancySource S>
    Tree build_from(const S& src) {
        auto t0 = std::chrono::steady_clock::now();
        Tree t;
        if (cfg_.planes == Planes::Binned) {
            block_words(src, verdicts_, *exec_, words_);
            gather_local_boxes(words_, order_, source_.spacing, boxes_);
            timings_.occupancy_ms = detail::ms_since(t0);
            t = build(boxes_, cfg_, *exec_);
        } else {
            psvt_.assign(src, *exec_);
            timings_.occupancy_ms = detail::ms_since(t0);
            t = build(psvt_, cfg_, *exec_);
        }
        timings_.split_ms = t.stats.split_ms;
        t.stats.occupancy_ms = timings_.classify_ms + timings_.occupancy_ms;
        return t;
    }

    BoxSource source_;
    const volume::Volume* volume_ = nullptr;
    const volume::DensityGrid* grid_ = nullptr;
    X* exec_;
    Config cfg_;
    RebuildTimings timings_;
    std::vector<std::uint8_t> table_;
    BlockOrder order_;
    BlockValues values_;
    double prepare_ms_ = 0.0;
    std::vector<std::uint32_t> scratch_;
    std::vector<std::uint8_t> verdicts_;
    std::vector<std::uint32_t> words_;
    LocalBoxes boxes_;
    volume::PartialSvt<32> psvt_;
};

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_REBUILD_HPP
