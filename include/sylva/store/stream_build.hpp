// sylva/store/stream_build.hpp -- builds a brick store from a volume read slice by slice, in
// bounded memory, producing exactly what octree::build + octree::encode would (the same nodes,
// ranges, neighbour pointers and bricks, bit for bit).
//
// octree::build holds the whole LoD pyramid. Here every pyramid level keeps only a window of
// its most recent z slices (B + 2 border + 2 of them): slices of level 0 come from the source;
// when level s has slices 2z and 2z + 1 it computes slice z of level s + 1 with the same
// weighted box filter (octree::detail::downsample's arithmetic, in the same order); as soon as
// a level holds every slice a row of nodes (one z coordinate) reads -- their voxels plus the
// border, clamped -- their bricks are filled, encoded on the worker threads, and written; the
// row's own [min, max] are kept per node. Once the last slice is in, every node's range is
// folded from its own and its children's (the in-core order), and the index is written.
// Memory: the windows (sum over levels of (B + 2 border + 2) * X_s * Y_s floats), the nodes,
// a batch of bricks in flight and one LMDB transaction (WriterConfig::batch_bytes).
#ifndef SYLVA_STORE_STREAM_BUILD_HPP
#define SYLVA_STORE_STREAM_BUILD_HPP

#include <algorithm>
#include <bit>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/octree/build.hpp"
#include "sylva/octree/encode.hpp"
#include "sylva/store/codec.hpp"
#include "sylva/store/format.hpp"
#include "sylva/store/slices.hpp"
#include "sylva/store/writer.hpp"

namespace sylva::store {

/// Where a streamed build stands (passed to StreamConfig::progress).
struct StreamProgress {
    std::uint64_t bricks_done = 0;   ///< bricks written or found already stored (resume)
    std::uint64_t bricks_total = 0;
    std::uint64_t slices_read = 0;   ///< source slices consumed
    std::uint64_t slices_total = 0;
    std::uint64_t source_bytes = 0;  ///< bytes of source voxels consumed
    double seconds = 0.0;
};

/// Settings of build_store.
struct StreamConfig {
    octree::Config octree{};        ///< brick size and border (octree::Config's defaults)
    Codec codec = Codec::zstd;      ///< brick compression
    int level = 1;                  ///< zstd level (1: the measured best rate; see the README)
    /// Bytes the build may hold (windows, nodes, bricks in flight, the open transaction); the
    /// build refuses to start when its plan needs more, naming what it needs.
    std::uint64_t memory_bytes = std::uint64_t{1} << 30;
    bool resume = false;            ///< add the bricks an interrupted build of the same input lacks
    WriterConfig writer{};          ///< batch_bytes is capped to memory_bytes / 8
    std::uint32_t batch_bricks = 64;  ///< bricks encoded in parallel between two writes
    std::function<void(const StreamProgress&)> progress;  ///< called after every batch
};

/// What build_store did.
struct StreamResult {
    BuildInfo info;
    std::uint64_t bricks_written = 0;
    std::uint64_t bricks_skipped = 0;  ///< already stored (resume)
    std::uint64_t brick_bytes_raw = 0;     ///< uncompressed bytes of the bricks written
    std::uint64_t brick_bytes_stored = 0;  ///< their encoded bytes
    std::uint64_t source_bytes = 0;
    std::uint64_t planned_memory = 0;
    double seconds = 0.0;
};

namespace detail {

/// The octree's nodes and neighbours without bricks (octree::build's, brick n = node n).
inline octree::Tree skeleton(volume::Dims dims, vec3 spacing, const octree::Config& cfg) {
    octree::detail::check_config(cfg);
    if (dims.x == 0 || dims.y == 0 || dims.z == 0 || dims.x > octree::kMaxDim || dims.y > octree::kMaxDim ||
        dims.z > octree::kMaxDim)
        throw Error("store: the volume is " + octree::detail::dims_text(dims) +
                    " voxels; every extent must be in [1, 2^24 - 1]");
    octree::Tree t;
    t.dims = dims;
    t.spacing = spacing;
    t.brick_size = cfg.brick_size;
    t.border = cfg.border;
    t.format = cfg.format;
    t.levels = octree::detail::level_count(dims, cfg.brick_size);
    if (t.levels > octree::kMaxLevels)
        throw Error("store: a " + octree::detail::dims_text(dims) + " volume needs " + std::to_string(t.levels) +
                    " levels, more than " + std::to_string(octree::kMaxLevels));
    t.nodes = octree::detail::complete_nodes(t);
    if (t.nodes.size() >= 0xFFFFFFFFu) throw Error("store: too many nodes");
    for (std::size_t n = 0; n < t.nodes.size(); ++n) t.nodes[n].brick = static_cast<std::uint32_t>(n);
    octree::link_neighbours(t);
    return t;
}

/// Slices kept per pyramid level.
inline std::uint32_t window_slices(const octree::Config& cfg) { return cfg.brick_size + 2u * cfg.border + 2u; }

/// Pyramid level s's extent: ceil(dims / 2^s).
inline volume::Dims level_dims(volume::Dims d, std::uint32_t s) {
    for (std::uint32_t i = 0; i < s; ++i) d = (d + 1u) / 2u;
    return d;
}

/// Hands encoded bricks to a StoreWriter on a thread of its own, so that LMDB's page writes and
/// fsyncs overlap the encoding. Holds at most `max_bytes` of bricks waiting; a writer error
/// (a full disk) is rethrown by the next push() or by finish().
class WriteQueue {
public:
    using Batch = std::vector<std::pair<std::uint32_t, std::vector<std::byte>>>;
    WriteQueue(StoreWriter& w, std::uint64_t max_bytes) : w_(w), max_(max_bytes), thread_([this] { loop(); }) {}
    WriteQueue(const WriteQueue&) = delete;
    WriteQueue& operator=(const WriteQueue&) = delete;
    ~WriteQueue() { stop(); }

    void push(Batch&& b) {
        std::uint64_t bytes = 0;
        for (auto& e : b) bytes += e.second.size();
        std::unique_lock lock(m_);
        drained_.wait(lock, [&] { return error_ || pending_ == 0 || pending_ + bytes <= max_; });
        if (error_) std::rethrow_exception(error_);
        pending_ += bytes;
        queue_.push_back(std::move(b));
        ready_.notify_one();
    }
    /// Writes what is queued, commits, and rethrows a writer error.
    void finish() {
        stop();
        if (error_) std::rethrow_exception(error_);
    }

private:
    void stop() {
        {
            std::lock_guard lock(m_);
            if (done_) return;
            done_ = true;
        }
        ready_.notify_one();
        thread_.join();
    }
    void loop() {
        for (;;) {
            Batch b;
            {
                std::unique_lock lock(m_);
                ready_.wait(lock, [&] { return done_ || !queue_.empty(); });
                if (queue_.empty()) break;
                b = std::move(queue_.front());
                queue_.pop_front();
            }
            std::uint64_t bytes = 0;
            try {
                for (auto& e : b) {
                    bytes += e.second.size();
                    if (!error_) w_.put(e.first, e.second);
                }
            } catch (...) {
                std::lock_guard lock(m_);
                error_ = std::current_exception();
            }
            std::lock_guard lock(m_);
            pending_ -= std::min(pending_, bytes);
            drained_.notify_all();
        }
        try {
            if (!error_) w_.commit();
        } catch (...) {
            std::lock_guard lock(m_);
            error_ = std::current_exception();
        }
    }

    StoreWriter& w_;
    std::uint64_t max_;
    std::mutex m_;
    std::condition_variable ready_, drained_;
    std::deque<Batch> queue_;
    std::uint64_t pending_ = 0;
    bool done_ = false;
    std::exception_ptr error_;
    std::thread thread_;  // last: starts after the members it uses
};

/// The streamed build (see the top of this header).
class StreamBuilder {
public:
    StreamBuilder(SliceSource& src, octree::Tree skel, const StreamConfig& cfg, StoreWriter* writer, ThreadPool& pool)
        : src_(src), t_(std::move(skel)), cfg_(cfg), writer_(writer), pool_(pool) {
        if (writer_) stored_ = writer_->stored_keys();
        const std::uint32_t cap = window_slices(cfg.octree);
        levels_.resize(t_.levels);
        for (std::uint32_t s = 0; s < t_.levels; ++s) {
            Level& L = levels_[s];
            L.dims = level_dims(t_.dims, s);
            L.slot_z.assign(cap, kNoSlice);
            L.slots.resize(cap);
            for (auto& v : L.slots) v.resize(std::size_t(L.dims.x) * L.dims.y);
        }
        own_.resize(t_.nodes.size());
        index_rows();
    }

    /// Bytes the windows, nodes and batch buffers take.
    [[nodiscard]] static std::uint64_t plan_bytes(const octree::Tree& t, const StreamConfig& cfg) {
        std::uint64_t b = 0;
        for (std::uint32_t s = 0; s < t.levels; ++s) {
            volume::Dims d = level_dims(t.dims, s);
            b += std::uint64_t(window_slices(cfg.octree)) * d.x * d.y * 4u;
        }
        b += t.nodes.size() * (sizeof(octree::Node) + 8u + 4u + 64u);  // nodes, own ranges, row lists, index
        b += std::uint64_t(cfg.batch_bricks) * t.brick_words() * 4u * 3u;  // words + shuffled + encoded
        return b;
    }

    void run(StreamResult& r) {
        start_ = std::chrono::steady_clock::now();
        std::optional<WriteQueue> queue;
        if (writer_) queue.emplace(*writer_, std::max<std::uint64_t>(cfg_.writer.batch_bytes, 4u << 20));
        queue_ = queue ? &*queue : nullptr;
        progress_.bricks_total = t_.nodes.size();
        progress_.slices_total = t_.dims.z;
        std::vector<float> slice(std::size_t(t_.dims.x) * t_.dims.y);
        for (std::uint32_t z = 0; z < t_.dims.z; ++z) {
            src_.read(z, slice, pool_);
            progress_.slices_read = z + 1u;
            progress_.source_bytes += src_.slice_source_bytes();
            push(0, z, slice);
        }
        if (queue_) queue_->finish();
        fold_ranges();
        r.bricks_written = written_;
        r.bricks_skipped = skipped_;
        r.brick_bytes_raw = written_ * std::uint64_t(t_.brick_words()) * 4u;
        r.brick_bytes_stored = stored_bytes_;
        r.source_bytes = progress_.source_bytes;
    }

    [[nodiscard]] const octree::Tree& tree() const { return t_; }

private:
    static constexpr std::uint32_t kNoSlice = 0xFFFFFFFFu;
    struct Level {
        volume::Dims dims{0};
        std::vector<std::vector<float>> slots;  ///< ring of slices, slot z % cap
        std::vector<std::uint32_t> slot_z;       ///< which slice each slot holds
        std::vector<float> incoming;             ///< the next slice, being downsampled into
        std::uint32_t next_row = 0;              ///< first row of nodes not yet emitted
        std::vector<std::uint32_t> order;        ///< the level's nodes by (z, y, x)
        std::vector<std::size_t> row_start;      ///< order[row_start[cz] .. row_start[cz + 1])
    };

    /// Slice z of level s (must be in the window).
    const float* slice(std::uint32_t s, std::uint32_t z) const {
        const Level& L = levels_[s];
        std::size_t slot = z % L.slots.size();
        if (L.slot_z[slot] != z) throw Error("store: internal error: slice outside the window");
        return L.slots[slot].data();
    }

    void index_rows() {
        for (std::uint32_t s = 0; s < t_.levels; ++s) {
            Level& L = levels_[s];
            const std::uint32_t l = t_.levels - 1u - s;
            for (std::uint32_t n = 0; n < t_.nodes.size(); ++n)
                if (t_.nodes[n].level == l) L.order.push_back(n);
            std::sort(L.order.begin(), L.order.end(), [&](std::uint32_t a, std::uint32_t b) {
                const auto &ca = t_.nodes[a].coord, &cb = t_.nodes[b].coord;
                return std::tie(ca.z, ca.y, ca.x) < std::tie(cb.z, cb.y, cb.x);
            });
            const std::uint32_t rows = t_.level_nodes(l).z;
            L.row_start.assign(rows + 1u, L.order.size());
            for (std::size_t i = L.order.size(); i-- > 0;) L.row_start[t_.nodes[L.order[i]].coord.z] = i;
        }
    }

    /// Stores slice z of level s, emits the rows it completes, and feeds the next level.
    void push(std::uint32_t s, std::uint32_t z, std::span<const float> data) {
        Level& L = levels_[s];
        std::size_t slot = z % L.slots.size();
        std::copy(data.begin(), data.end(), L.slots[slot].begin());
        L.slot_z[slot] = z;
        const std::uint32_t b = t_.brick_size, rows = std::uint32_t(L.row_start.size() - 1u);
        while (L.next_row < rows && std::min(L.next_row * b + b + t_.border - 1u, L.dims.z - 1u) <= z)
            emit_row(s, L.next_row++);
        if (s + 1u < t_.levels && ((z & 1u) == 1u || z + 1u == L.dims.z)) {
            std::vector<float>& coarse = levels_[s + 1u].incoming;
            coarse.resize(std::size_t(levels_[s + 1u].dims.x) * levels_[s + 1u].dims.y);
            downsample(s, z / 2u, coarse);
            push(s + 1u, z / 2u, coarse);
        }
    }

    /// Slice zc of level s + 1 from slices 2 zc and 2 zc + 1 of level s, with
    /// octree::detail::downsample's weights and summation order. Where all 8 fine voxels exist
    /// and each covers 2^s voxels a side (all but the far edges), every weight is the same
    /// power of two w = 8^s: w * v, their running sum and the division by 8 w are then w times
    /// (and 1 / 8 w times) the same double operations on the plain values, so the sum of the 8
    /// values in the same order times 0.125 gives the same bits, without the weights.
    void downsample(std::uint32_t s, std::uint32_t zc, std::vector<float>& out) {
        const volume::Dims fine = levels_[s].dims, coarse = levels_[s + 1u].dims, full = t_.dims;
        const float* planes[2] = {slice(s, 2u * zc), 2u * zc + 1u < fine.z ? slice(s, 2u * zc + 1u) : nullptr};
        // Coarse index c is interior along an axis when its second fine voxel 2c + 1 exists and
        // covers 2^s voxels: (2c + 2) * 2^s <= the full extent.
        auto interior = [&](std::uint32_t c, std::uint32_t fine_n, std::uint32_t full_n) {
            return 2u * c + 1u < fine_n && (std::uint64_t{2u * c + 2u} << s) <= full_n;
        };
        std::uint32_t fast_x = 0;
        while (fast_x < coarse.x && interior(fast_x, fine.x, full.x)) ++fast_x;
        const bool fast_z = interior(zc, fine.z, full.z);
        pool_.parallel_for(0, coarse.y, 8, [&](std::size_t y0, std::size_t y1) {
            for (std::uint32_t y = std::uint32_t(y0); y < y1; ++y) {
                std::uint32_t x = 0;
                if (fast_z && interior(y, fine.y, full.y)) {
                    const std::size_t r0 = std::size_t(fine.x) * (2u * y), r1 = r0 + fine.x;
                    const float *a = planes[0] + r0, *b = planes[0] + r1, *c = planes[1] + r0, *d = planes[1] + r1;
                    float* o = out.data() + std::size_t(coarse.x) * y;
                    for (; x < fast_x; ++x) {
                        const std::uint32_t f = 2u * x;
                        double sum = 0.0;  // as the weighted sum starts (0.0 + -0.0 is +0.0)
                        sum += double(a[f]);  // octant order: x, then y, then z
                        sum += double(a[f + 1u]);
                        sum += double(b[f]);
                        sum += double(b[f + 1u]);
                        sum += double(c[f]);
                        sum += double(c[f + 1u]);
                        sum += double(d[f]);
                        sum += double(d[f + 1u]);
                        o[x] = float(sum * 0.125);
                    }
                }
                for (; x < coarse.x; ++x) {
                    double sum = 0.0, weight = 0.0;
                    for (std::uint32_t o = 0; o < 8; ++o) {
                        glm::u32vec3 f(2 * x + (o & 1u), 2 * y + ((o >> 1) & 1u), 2 * zc + (o >> 2));
                        if (f.x >= fine.x || f.y >= fine.y || f.z >= fine.z) continue;
                        double w = double(octree::detail::covered(f.x, s, full.x)) *
                                   octree::detail::covered(f.y, s, full.y) * octree::detail::covered(f.z, s, full.z);
                        sum += w * planes[o >> 2][f.x + std::size_t(fine.x) * f.y];
                        weight += w;
                    }
                    out[x + std::size_t(coarse.x) * y] = float(sum / weight);
                }
            }
        });
    }

    /// octree::detail::fill_brick over the window (the same clamped samples, read row by row,
    /// in the tree's format: float32 bits, or 2 / 4 rounded samples a word, low bits first).
    void fill_brick(std::uint32_t s, const octree::Node& node, std::uint32_t* out) const {
        const std::uint32_t side = t_.brick_side();
        const glm::ivec3 lo = glm::ivec3(node.coord * t_.brick_size) - int(t_.border);
        const glm::ivec3 top = glm::ivec3(levels_[s].dims) - 1;
        const std::size_t row = levels_[s].dims.x;
        std::uint32_t xs[64 + 4];
        for (std::uint32_t x = 0; x < side; ++x) xs[x] = std::uint32_t(std::clamp(lo.x + int(x), 0, top.x));
        // Bits a sample (0: float32 words); a constant in each loop, so j / per word is a shift.
        auto rows = [&]<std::uint32_t Bits>() {
            constexpr std::uint32_t max = Bits ? (1u << Bits) - 1u : 0u, per_word = Bits ? 32u / Bits : 1u;
            if constexpr (Bits != 0u) std::fill(out, out + t_.brick_words(), 0u);
            std::uint32_t j = 0;
            for (std::uint32_t z = 0; z < side; ++z) {
                const float* plane = slice(s, std::uint32_t(std::clamp(lo.z + int(z), 0, top.z)));
                for (std::uint32_t y = 0; y < side; ++y) {
                    const float* line = plane + row * std::uint32_t(std::clamp(lo.y + int(y), 0, top.y));
                    for (std::uint32_t x = 0; x < side; ++x, ++j) {
                        if constexpr (Bits == 0u) out[j] = std::bit_cast<std::uint32_t>(line[xs[x]]);
                        else out[j / per_word] |= octree::detail::quantise(line[xs[x]], max) << ((j % per_word) * Bits);
                    }
                }
            }
        };
        if (t_.format == octree::BrickFormat::Unorm16) rows.template operator()<16u>();
        else if (t_.format == octree::BrickFormat::Unorm8) rows.template operator()<8u>();
        else rows.template operator()<0u>();
    }

    /// octree::detail::own_range over the window (same voxels, same order).
    std::pair<float, float> own_range(std::uint32_t s, const octree::Node& node) const {
        const volume::Dims d = levels_[s].dims;
        glm::u32vec3 lo = glm::max(glm::ivec3(node.coord * t_.brick_size) - 1, glm::ivec3(0));
        glm::u32vec3 hi = glm::min((node.coord + 1u) * t_.brick_size, d - 1u);
        float a = std::numeric_limits<float>::infinity(), b = -a;
        for (std::uint32_t z = lo.z; z <= hi.z; ++z) {
            const float* plane = slice(s, z);
            for (std::uint32_t y = lo.y; y <= hi.y; ++y) {
                const float* line = plane + std::size_t(d.x) * y;
                for (std::uint32_t x = lo.x; x <= hi.x; ++x) {
                    float v = line[x];
                    a = std::min(a, v);
                    b = std::max(b, v);
                }
            }
        }
        return {a, b};
    }

    /// Ranges and bricks of row cz of level s, in batches encoded on the pool.
    void emit_row(std::uint32_t s, std::uint32_t cz) {
        const Level& L = levels_[s];
        const std::size_t words = t_.brick_words();
        for (std::size_t i = L.row_start[cz]; i < L.row_start[cz + 1u]; i += cfg_.batch_bricks) {
            const std::size_t n = std::min<std::size_t>(cfg_.batch_bricks, L.row_start[cz + 1u] - i);
            batch_.resize(n);
            todo_.assign(n, 1);
            for (std::size_t j = 0; j < n; ++j) todo_[j] = stored_.empty() || !stored_[L.order[i + j]];
            pool_.parallel_for(0, n, 1, [&](std::size_t j0, std::size_t j1) {
                thread_local std::vector<std::uint32_t> words_buf;
                words_buf.resize(words);
                for (std::size_t j = j0; j < j1; ++j) {
                    const std::uint32_t node = L.order[i + j];
                    auto [a, b] = own_range(s, t_.nodes[node]);
                    // Rounding is monotonic: the stored samples' range (octree::build's).
                    own_[node] = {octree::detail::stored_density(a, t_.format),
                                  octree::detail::stored_density(b, t_.format)};
                    if (!todo_[j]) continue;
                    fill_brick(s, t_.nodes[node], words_buf.data());
                    encode_brick(words_buf, cfg_.codec, cfg_.level, batch_[j]);
                }
            });
            WriteQueue::Batch out;
            for (std::size_t j = 0; j < n; ++j) {
                if (!todo_[j]) {
                    ++skipped_;
                    continue;
                }
                stored_bytes_ += batch_[j].size();
                ++written_;
                if (queue_) out.emplace_back(L.order[i + j], std::move(batch_[j]));
            }
            if (queue_ && !out.empty()) queue_->push(std::move(out));
            report();
        }
    }

    void report() {
        if (!cfg_.progress) return;
        progress_.bricks_done = written_ + skipped_;
        progress_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        cfg_.progress(progress_);
    }

    /// Node ranges: own range, then the children's in octant order (octree::build's order);
    /// children are stored after their parents, so walking the nodes backwards finds them done.
    void fold_ranges() {
        for (std::size_t n = t_.nodes.size(); n-- > 0;) {
            octree::Node& node = t_.nodes[n];
            auto [a, b] = own_[n];
            for (std::uint32_t o = 0, c = node.first_child; o < 8; ++o) {
                if (((node.child_mask >> o) & 1u) == 0u) continue;
                a = std::min(a, t_.nodes[c].min);
                b = std::max(b, t_.nodes[c].max);
                ++c;
            }
            node.min = a;
            node.max = b;
        }
    }

    SliceSource& src_;
    octree::Tree t_;
    const StreamConfig& cfg_;
    StoreWriter* writer_;
    ThreadPool& pool_;
    std::vector<Level> levels_;
    std::vector<std::pair<float, float>> own_;
    std::vector<std::vector<std::byte>> batch_;
    std::vector<char> todo_;
    std::vector<char> stored_;          ///< per key: already stored (resume)
    WriteQueue* queue_ = nullptr;
    std::uint64_t written_ = 0, skipped_ = 0, stored_bytes_ = 0;
    StreamProgress progress_;
    std::chrono::steady_clock::time_point start_;
};

}  // namespace detail

/// The index words a store of `t` (nodes and ranges final) holds: octree::encode with brick
/// state SYLVA_OCT_BRICK_HOST and one brick per node.
inline std::vector<std::uint32_t> store_index(const octree::Tree& t) {
    std::vector<std::uint32_t> w = octree::encode(t, SYLVA_OCT_BRICK_HOST);
    w[7] = static_cast<std::uint32_t>(t.nodes.size());
    return w;
}

/// The brick format `sylva-store build` chooses for a source of `voxel_type`: unorm16 for
/// uint8 and uint16 volumes (the paper's 16-bit texels: half the bytes of float32 to compress,
/// store and cache; a uint8 or uint16 volume over its type's range loses nothing, a narrower
/// range rounds by at most 0.5 / 65535 and keeps every voxel value apart), float32
/// for float volumes (whose densities are not on a grid of steps).
inline octree::BrickFormat default_brick_format(std::string_view voxel_type) {
    return voxel_type == "uint8" || voxel_type == "uint16" ? octree::BrickFormat::Unorm16 : octree::BrickFormat::Float32;
}

/// `sylva-store build --brick-format CHOICE` for a source of `voxel_type`: "auto" is
/// default_brick_format, anything else a format's name (brick_format_from_name).
inline octree::BrickFormat brick_format_for(std::string_view choice, std::string_view voxel_type) {
    return choice == "auto" ? default_brick_format(voxel_type) : brick_format_from_name(choice);
}

/// The BuildInfo build_store writes for `src` under `cfg`, named `input`.
inline BuildInfo plan_info(const SliceSource& src, const std::string& input, const StreamConfig& cfg) {
    octree::Tree t = detail::skeleton(src.dims(), src.spacing(), cfg.octree);
    BuildInfo b;
    b.input = input;
    b.dims = src.dims();
    b.spacing = src.spacing();
    b.voxel_type = src.voxel_type();
    b.range_lo = src.range_lo();
    b.range_hi = src.range_hi();
    b.range_source = src.range_source();
    b.brick_size = cfg.octree.brick_size;
    b.border = cfg.octree.border;
    b.levels = t.levels;
    b.node_count = static_cast<std::uint32_t>(t.nodes.size());
    b.codec = cfg.codec;
    b.level = cfg.codec == Codec::zstd ? cfg.level : 0;
    b.brick_format = cfg.octree.format;
    return b;
}

/// Memory the streamed build of `src` plans to hold (without the source's own, which
/// SliceSource::memory_bytes reports).
inline std::uint64_t plan_memory(const SliceSource& src, const StreamConfig& cfg) {
    octree::Tree t = detail::skeleton(src.dims(), src.spacing(), cfg.octree);
    std::uint64_t batch = std::min<std::uint64_t>(cfg.writer.batch_bytes, cfg.memory_bytes / 8u);
    return detail::StreamBuilder::plan_bytes(t, cfg) + batch + std::uint64_t(src.dims().x) * src.dims().y * 4u;
}

/// Builds the store at `path` from `src` (see the top of this header). `input` names the source
/// in the store's BuildInfo (resume compares it). Throws sylva::Error when the plan exceeds
/// cfg.memory_bytes, for bad configurations and sources, when the store exists (unless
/// resuming the same build), and DiskFullError when the disk fills (the store stays incomplete).
inline StreamResult build_store(SliceSource& src, const std::string& input, const std::filesystem::path& path,
                                const StreamConfig& cfg, ThreadPool& pool) {
    auto t0 = std::chrono::steady_clock::now();
    StreamResult r;
    r.info = plan_info(src, input, cfg);
    r.planned_memory = plan_memory(src, cfg) + src.memory_bytes();
    if (r.planned_memory > cfg.memory_bytes)
        throw Error("store: building " + input + " (" + octree::detail::dims_text(src.dims()) + ", bricks of " +
                    std::to_string(cfg.octree.brick_size) + ") needs about " + bytes_text(double(r.planned_memory)) +
                    " of memory (slice windows, nodes, bricks in flight" +
                    (src.memory_bytes() ? ", the source grid" : "") + "), more than --memory " +
                    bytes_text(double(cfg.memory_bytes)));
    WriterConfig wc = cfg.writer;
    wc.batch_bytes = std::min<std::uint64_t>(wc.batch_bytes, std::max<std::uint64_t>(cfg.memory_bytes / 8u, 1u << 20));
    StoreWriter w = StoreWriter::create(path, r.info, cfg.resume, wc);
    detail::StreamBuilder b(src, detail::skeleton(src.dims(), src.spacing(), cfg.octree), cfg, &w, pool);
    b.run(r);
    w.finish(store_index(b.tree()));
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_STREAM_BUILD_HPP
