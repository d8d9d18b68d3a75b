// sylva/octree/residency.hpp -- the out-of-core working set of the bricked octree (Gobbetti,
// Marton, Iglesias Guitian, section 5 and Fig. 2; section 6 for the visibility feedback): a
// host cache of decompressed bricks (brick_cache.hpp), a device brick pool of fixed slot count
// (lru.hpp's SlotPool over the caller's pool buffer), an asynchronous loader (loader.hpp) reading
// through a BrickSource (brick_source.hpp), and the per-frame refinement that builds the working
// set from the root using only what is resident.
//
//   TreeBrickSource src(octree::build(grid));          // or the on-disk store
//   ResidencyConfig cfg{.host_budget_bytes = 256 << 20, .device_budget_bytes = 128 << 20};
//   HostBrickPool pool(pool_slots(src.index(), cfg), src.index()[8]);
//   Residency res(src, pool, cfg);
//   for (each frame) {
//       const ResidencyFrame& f = res.update(cut_view(cam, w, h), terminal);
//       render(OctreeView{f.words, pool.words, ~0u, res.feedback()});  // writes the feedback
//   }
//
// Refinement (section 5, "the refinement procedure stops when all nodes are considered
// adequately refined, no data is currently available in-core to perform a refinement, or no more
// space is available"): from the root, the working-set node whose voxels project largest
// (cut.hpp's projected_voxel) is refined first, while that projection exceeds lod_pixels, the
// set stays within max_nodes and the pinned bricks within the pool's slots. A node is refined
// only when every child that is not terminal (empty under the TF / the iso value) has its brick
// in the device pool, uploading from the host cache what is there (at most
// max_uploads_per_frame bricks a frame: section 7's "texture upload budget"); the whole working
// set, inner nodes included, stays in the pool (section 5: "all nodes in the current working set
// are present both in the CPU and GPU cache"), so the next frame can refine it again without
// uploads; the bricks still
// on disk are requested from the loader (priority: the node's projected voxel size) and the
// node is drawn meanwhile. No frame waits for I/O, except the root's brick, read once by the
// constructor; the root's brick never leaves the pool (every frame can draw something).
// With visibility feedback (section 6) a node is refined only when a ray reached it
// in the previous frame (a cut leaf: the renderer's feedback word; an inner node: any of its
// children; a node below the previous cut: its ancestor cut leaf's); the first frame, with no
// feedback yet, counts every node seen.
//
// Bad bricks: a brick the source reports missing or corrupt is reported once (stderr and
// ResidencyCounters::bad_bricks) and never requested again; the node's parent stays a leaf of
// the cut for good, so its (good) brick is drawn instead.
//
// The frame index (ResidencyFrame::words) is the source's index with word 7 = the pool's slot
// count (the pool is the brick buffer bound beside it) and, for each node with a brick: state
// SYLVA_OCT_BRICK_RESIDENT and word +12 = its slot when resident in the pool, else state
// SYLVA_OCT_BRICK_HOST and word +12 = 0 (never read: the integrators sample resident bricks
// only, sylva/shared/octree_dvr.h); the cut's bits (cut.hpp) mark the working set. Every cut
// leaf that is not terminal is resident. octree::validate accepts it with the pool's words.
#ifndef SYLVA_OCTREE_RESIDENCY_HPP
#define SYLVA_OCTREE_RESIDENCY_HPP

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <iostream>
#include <optional>
#include <queue>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/octree/brick_cache.hpp"
#include "sylva/octree/brick_source.hpp"
#include "sylva/octree/cut.hpp"
#include "sylva/octree/loader.hpp"
#include "sylva/octree/lru.hpp"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

/// Budgets and policies of the out-of-core working set.
struct ResidencyConfig {
    /// Host cache of decompressed bricks, bytes (sylva-render --memory-budget; the paper's CPU
    /// cache). At least one brick.
    std::size_t host_budget_bytes = std::size_t{256} << 20;
    /// Device brick pool, bytes (--device-budget; the paper's 600 MB GPU cache): floor(budget /
    /// brick bytes) slots, at least 1.
    std::size_t device_budget_bytes = std::size_t{128} << 20;
    /// Refine while a node's voxel projects larger than this many pixels (the paper: 1). > 0.
    float lod_pixels = 1.0f;
    /// Working-set nodes (inner nodes and cut leaves), >= 1.
    std::uint32_t max_nodes = 1u << 20;
    /// Bricks copied from the host cache into the device pool per frame (section 7: frame-rate
    /// jitter "could be avoided by introducing a texture upload budget"). >= 1.
    std::uint32_t max_uploads_per_frame = 512;
    /// Refine only nodes a ray reached in the previous frame (section 6).
    bool visibility_feedback = true;
    /// Report bad bricks on stderr (once each; always counted).
    bool report_bad_bricks = true;
};

/// What a pool buffer must offer: write one brick into a slot.
template <class P>
concept BrickPoolBuffer = requires(P& p, std::uint32_t slot, std::span<const std::uint32_t> brick) {
    { p.write_brick(slot, brick) };
};

/// The host renderer's device pool: `slots` bricks in one word buffer (zeroed).
struct HostBrickPool {
    std::vector<std::uint32_t> words;
    std::uint32_t brick_words = 0;
    HostBrickPool(std::uint32_t slots, std::uint32_t brick_words_)
        : words(std::size_t{slots} * brick_words_, 0u), brick_words(brick_words_) {}
    void write_brick(std::uint32_t slot, std::span<const std::uint32_t> brick) {
        if (brick.size() != brick_words || std::size_t{slot + 1u} * brick_words > words.size())
            throw Error("HostBrickPool: slot or brick size out of range");
        std::copy(brick.begin(), brick.end(), words.begin() + std::ptrdiff_t(std::size_t{slot} * brick_words));
    }
};

static_assert(BrickPoolBuffer<HostBrickPool>);

/// Slots of the device pool under cfg for the index `words` (word 8: brick words).
inline std::uint32_t pool_slots(std::span<const std::uint32_t> words, const ResidencyConfig& cfg) {
    if (words.size() < SYLVA_OCT_HEADER_WORDS || words[8] == 0u) throw Error("residency: not a valid encoded octree");
    std::size_t brick_bytes = std::size_t{words[8]} * 4u;
    std::size_t slots = cfg.device_budget_bytes / brick_bytes;
    if (slots < 1u)
        throw Error("residency: a device budget of " + std::to_string(cfg.device_budget_bytes) +
                    " bytes holds no brick of " + std::to_string(brick_bytes) + " bytes");
    return static_cast<std::uint32_t>(std::min<std::size_t>({slots, words[7], 0xFFFFFFFFu / words[8]}));
}

/// Cumulative counters of a Residency.
struct ResidencyCounters {
    std::uint64_t frames = 0;
    std::uint64_t uploads = 0;           ///< bricks copied host cache -> device pool
    std::uint64_t device_evicted = 0;    ///< pool slots reassigned
    std::uint64_t device_hits = 0;       ///< wanted bricks found in the pool
    std::uint64_t device_misses = 0;     ///< wanted bricks not in the pool
    std::uint64_t requested = 0;         ///< requests sent to the loader (per frame, summed)
    std::uint64_t bad_bricks = 0;        ///< missing or corrupt bricks reported (once each)
    std::uint64_t feedback_blocked = 0;  ///< refinements skipped: not seen in the previous frame
};

/// One frame's working set.
struct ResidencyFrame {
    std::vector<std::uint32_t> words;  ///< the frame index (top of this header)
    Cut cut;                           ///< the working set (cut.hpp)
    std::uint32_t uploads = 0;         ///< bricks uploaded to the pool this frame
    std::uint32_t requests = 0;        ///< bricks requested from the loader this frame
    std::uint64_t loaded = 0;          ///< bricks the loader cached since the previous frame
    std::uint32_t resident = 0;        ///< pool slots in use
    std::uint32_t waiting = 0;         ///< nodes left unrefined because a brick was not resident
    double ms = 0.0;                   ///< time of update()
};

/// The out-of-core working set over source S and pool buffer P (see the top of this header).
template <BrickSource S, BrickPoolBuffer P>
class Residency {
public:
    /// Reads the root's brick synchronously (the only blocking read). Throws sylva::Error on an
    /// invalid index or budgets.
    Residency(const S& source, P& pool, const ResidencyConfig& cfg)
        : source_(source), pool_(pool), cfg_(cfg), index_(source.index()), cache_(cfg.host_budget_bytes),
          slots_(pool_slots(index_, cfg)), loader_(source, cache_) {
        check();
        std::size_t n = header_.node_count;
        parent_.assign(n, kNone);
        node_of_key_.assign(header_.brick_count, kNone);
        for (std::uint32_t i = 0; i < n; ++i) {
            std::uint32_t f = shared::sylva_oct_flags(buf(), i), first = shared::sylva_oct_first_child(buf(), i);
            std::uint32_t kids = static_cast<std::uint32_t>(std::popcount(shared::sylva_oct_child_mask(f)));
            for (std::uint32_t k = 0; k < kids && first + k < n; ++k) parent_[first + k] = i;
            std::uint32_t key = key_of(i);
            if (key != kNone && key < header_.brick_count) node_of_key_[key] = i;
        }
        bad_.assign(header_.brick_count, 0u);
        seen_.assign(n, 0u);
        prev_state_.assign(n, CutState::Below);
        frame_.words.assign(index_.begin(), index_.end());
        frame_.words[7] = slots_.slots();
        load_root();
    }

    /// Builds this frame's working set for view v; `terminal(n)` true: node n is never refined
    /// (empty under the TF or the iso value: select_octree_cut's predicate). Consumes the
    /// feedback the previous frame's renderer wrote and clears it for this frame.
    template <class Terminal>
    const ResidencyFrame& update(const CutView& v, Terminal&& terminal) {
        auto t0 = std::chrono::steady_clock::now();
        take_failures();
        std::vector<std::uint8_t> seen = seen_previous();
        std::fill(seen_.begin(), seen_.end(), 0u);
        std::uint64_t loaded = loader_.counters().loaded;
        frame_.loaded = loaded - loaded_before_;
        loaded_before_ = loaded;
        frame_.uploads = 0;
        frame_.waiting = 0;
        requests_.clear();
        slots_.unpin_all();
        refine(v, terminal, seen);
        frame_.requests = static_cast<std::uint32_t>(requests_.size());
        counters_.requested += requests_.size();
        loader_.submit(requests_);
        write_frame_index();
        prev_state_ = frame_.cut.state;
        first_frame_ = false;
        ++counters_.frames;
        frame_.resident = slots_.used();
        frame_.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        return frame_;
    }

    /// The feedback buffer the renderer writes this frame (one word per node; nonzero: a ray
    /// reached the node before terminating; sylva/shared/octree_dvr.h).
    [[nodiscard]] std::span<std::uint32_t> feedback() { return seen_; }
    [[nodiscard]] const ResidencyFrame& frame() const { return frame_; }
    [[nodiscard]] const ResidencyCounters& counters() const { return counters_; }
    [[nodiscard]] HostCacheCounters host_counters() const { return cache_.counters(); }
    [[nodiscard]] LoaderCounters loader_counters() const { return loader_.counters(); }
    [[nodiscard]] const HostBrickCache& host_cache() const { return cache_; }
    [[nodiscard]] std::uint32_t slots() const { return slots_.slots(); }
    [[nodiscard]] std::uint32_t pinned() const { return slots_.pinned_count(); }
    [[nodiscard]] const SlotPool& pool_slots_state() const { return slots_; }
    [[nodiscard]] std::size_t brick_bytes() const { return std::size_t{header_.brick_words} * 4u; }
    /// Bytes of the device pool buffer (all slots).
    [[nodiscard]] std::size_t device_pool_bytes() const { return std::size_t{slots_.slots()} * brick_bytes(); }
    /// True when brick `key` was reported bad.
    [[nodiscard]] bool bad(std::uint32_t key) const { return key < bad_.size() && bad_[key] != 0u; }
    /// Waits until the loader has read everything requested (tests and benchmarks).
    void wait_loads() { loader_.wait_idle(); }
    [[nodiscard]] const shared::SylvaOctHeader& header() const { return header_; }

private:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

    [[nodiscard]] shared::Words buf() const { return shared::Words{index_.data(), index_.size()}; }
    [[nodiscard]] std::uint32_t key_of(std::uint32_t n) const { return shared::sylva_oct_brick(buf(), n); }

    void check() {
        if (!(cfg_.lod_pixels > 0.0f)) throw Error("residency: lod_pixels must be > 0");
        if (cfg_.max_nodes < 1u || cfg_.max_uploads_per_frame < 1u) throw Error("residency: budgets must be >= 1");
        if (index_.size() < SYLVA_OCT_HEADER_WORDS || index_.size() > 0xFFFFFFFFu)
            throw Error("residency: not a valid encoded octree");
        std::uint64_t bw = std::uint64_t{index_[7]} * index_[8];
        if (bw > 0xFFFFFFFFu) throw Error("residency: the source's bricks exceed 2^32 words");
        header_ = shared::sylva_oct_read_header(buf(), static_cast<std::uint32_t>(index_.size()), static_cast<std::uint32_t>(bw));
        if (header_.valid == 0u) throw Error("residency: the source's index is not a valid encoded octree");
        if (cfg_.host_budget_bytes < brick_bytes())
            throw Error("residency: a host budget of " + std::to_string(cfg_.host_budget_bytes) +
                        " bytes holds no brick of " + std::to_string(brick_bytes()) + " bytes");
    }

    void load_root() {
        std::uint32_t key = key_of(0);
        if (key == kNone) return;
        std::vector<std::uint32_t> b(header_.brick_words);
        BrickStatus s = source_.read_brick(key, b);
        if (s != BrickStatus::ok) {
            mark_bad(key, s);
            return;
        }
        cache_.put(key, b);
        std::uint32_t evicted;
        std::optional<std::uint32_t> slot = slots_.assign(key, evicted);
        pool_.write_brick(*slot, b);
        ++counters_.uploads;
    }

    void mark_bad(std::uint32_t key, BrickStatus s) {
        if (key >= bad_.size() || bad_[key]) return;
        bad_[key] = 1u;
        ++counters_.bad_bricks;
        slots_.release(key);
        if (cfg_.report_bad_bricks)
            std::cerr << "sylva: brick " << key << " (node " << node_of_key_[key] << ") is "
                      << (s == BrickStatus::corrupt ? "corrupt" : "missing") << "; its parent is drawn instead\n";
    }

    void take_failures() {
        for (auto [key, s] : loader_.take_failures()) mark_bad(key, s);
    }

    /// Per node: seen in the previous frame (top of this header).
    std::vector<std::uint8_t> seen_previous() const {
        std::size_t n = seen_.size();
        std::vector<std::uint8_t> v(n, 1u);
        if (first_frame_ || !cfg_.visibility_feedback) return v;
        for (std::size_t i = 0; i < n; ++i) {
            if (prev_state_[i] == CutState::Leaf) v[i] = seen_[i] != 0u ? 1u : 0u;
            if (prev_state_[i] == CutState::Inner) v[i] = 0u;
        }
        for (std::size_t i = n; i-- > 0;)  // children after parents: bottom-up, an inner node = any child
            if (prev_state_[i] != CutState::Below && v[i] && parent_[i] != kNone) v[parent_[i]] = 1u;
        for (std::size_t i = 0; i < n; ++i)  // below the cut: the ancestor cut leaf's
            if (prev_state_[i] == CutState::Below && parent_[i] != kNone) v[i] = v[parent_[i]];
        return v;
    }

    /// The brick of node c made resident and pinned, if possible now (counts hits, uploads).
    /// false: not resident; then requested unless bad.
    bool make_resident(std::uint32_t c, float priority, std::vector<std::uint32_t>& tmp) {
        std::uint32_t key = key_of(c);
        if (std::optional<std::uint32_t> s = slots_.find(key)) {
            ++counters_.device_hits;
            slots_.pin(*s);
            return true;
        }
        ++counters_.device_misses;
        if (frame_.uploads < cfg_.max_uploads_per_frame && cache_.copy_to(key, tmp)) {
            std::uint32_t evicted;
            std::optional<std::uint32_t> s = slots_.assign(key, evicted);
            if (!s) return false;  // every slot pinned: the pool is full this frame
            if (evicted != SlotPool::kFree) ++counters_.device_evicted;
            pool_.write_brick(*s, tmp);
            slots_.pin(*s);
            ++frame_.uploads;
            ++counters_.uploads;
            return true;
        }
        if (!cache_.contains(key)) requests_.push_back({key, priority});
        return false;
    }

    /// True when child c needs a brick to be drawn (not terminal, has a brick).
    template <class Terminal>
    bool needs_brick(std::uint32_t c, Terminal& terminal) const {
        return key_of(c) != kNone && !terminal(c);
    }

    template <class Terminal>
    void refine(const CutView& v, Terminal& terminal, const std::vector<std::uint8_t>& seen) {
        using namespace sylva::shared;
        Cut& cut = frame_.cut;
        cut.state.assign(header_.node_count, CutState::Below);
        cut.nodes = cut.leaves = cut.deepest = 0;
        std::priority_queue<std::pair<float, std::uint32_t>> open;
        auto add = [&](std::uint32_t n) {
            cut.state[n] = CutState::Leaf;
            cut.nodes += 1;
            open.emplace(detail::projected_voxel(header_, sylva_oct_level(sylva_oct_flags(buf(), n)), sylva_oct_coord(buf(), n), v), n);
        };
        add(0u);
        if (std::optional<std::uint32_t> s = slots_.find(key_of(0))) slots_.pin(*s);  // the root stays, always
        std::vector<std::uint32_t> tmp(header_.brick_words);
        std::uint64_t promised = 0;  // bricks of waiting nodes not resident yet
        while (!open.empty()) {
            auto [size, n] = open.top();
            if (!(size > cfg_.lod_pixels)) break;
            open.pop();
            std::uint32_t f = sylva_oct_flags(buf(), n), mask = sylva_oct_child_mask(f);
            if (mask == 0u || terminal(n)) continue;
            std::uint32_t kids = static_cast<std::uint32_t>(std::popcount(mask)), first = sylva_oct_first_child(buf(), n);
            bool blocked = false;
            for (std::uint32_t k = 0; k < kids; ++k) blocked = blocked || (needs_brick(first + k, terminal) && bad(key_of(first + k)));
            if (blocked) continue;  // a bad child brick: this node is drawn for good
            if (!seen[n]) {
                ++counters_.feedback_blocked;
                continue;
            }
            if (std::uint64_t{cut.nodes} + kids > cfg_.max_nodes) break;  // the node budget
            std::uint32_t need = 0;
            for (std::uint32_t k = 0; k < kids; ++k) need += needs_brick(first + k, terminal) ? 1u : 0u;
            // The device budget, counting the bricks already promised to waiting nodes: no more
            // is requested than the pool could take (requests beyond it would only churn the
            // host cache).
            if (std::uint64_t{slots_.pinned_count()} + promised + need > slots_.slots()) break;
            std::uint32_t missing = 0;
            for (std::uint32_t k = 0; k < kids; ++k)
                if (needs_brick(first + k, terminal) && !make_resident(first + k, size, tmp)) ++missing;
            if (missing > 0) {
                ++frame_.waiting;
                promised += missing;
                continue;  // drawn meanwhile; its resident children stay pinned this frame
            }
            cut.state[n] = CutState::Inner;  // stays pinned: next frame refines it again from these bricks
            for (std::uint32_t k = 0; k < kids; ++k) add(first + k);
        }
        for (std::uint32_t n = 0; n < header_.node_count; ++n)
            if (cut.state[n] == CutState::Leaf) {
                cut.leaves += 1;
                cut.deepest = std::max(cut.deepest, sylva_oct_level(sylva_oct_flags(buf(), n)));
            }
    }

    void write_frame_index() {
        std::vector<std::uint32_t>& w = frame_.words;
        for (std::uint32_t n = 0; n < header_.node_count; ++n) {
            std::size_t at = shared::sylva_oct_node_at(n);
            std::uint32_t key = index_[at + 12];
            std::uint32_t flags = index_[at + 1] & ~(3u << 16);
            if (key == kNone) {
                w[at + 1] = flags;
                continue;
            }
            std::optional<std::uint32_t> s = slots_.find(key);
            w[at + 1] = flags | ((s ? SYLVA_OCT_BRICK_RESIDENT : SYLVA_OCT_BRICK_HOST) << 16);
            w[at + 12] = s ? *s : 0u;
        }
        apply_cut(w, frame_.cut);
    }

    const S& source_;
    P& pool_;
    ResidencyConfig cfg_;
    std::span<const std::uint32_t> index_;
    shared::SylvaOctHeader header_{};
    HostBrickCache cache_;
    SlotPool slots_;
    std::vector<std::uint32_t> parent_, node_of_key_, seen_;
    std::vector<std::uint8_t> bad_;
    std::vector<CutState> prev_state_;
    std::vector<BrickRequest> requests_;
    ResidencyFrame frame_;
    ResidencyCounters counters_;
    std::uint64_t loaded_before_ = 0;
    bool first_frame_ = true;
    BrickLoader<S> loader_;  ///< last member: its thread stops first
};

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_RESIDENCY_HPP
