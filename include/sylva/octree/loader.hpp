// sylva/octree/loader.hpp -- the asynchronous brick loader (Gobbetti, Marton, Iglesias Guitian,
// section 5 and Fig. 2: "data loading is performed asynchronously by a separate thread, and
// refinement continues only if data is immediately available"): one std::jthread reads the
// bricks the refinement asks for through a BrickSource (sylva/octree/brick_source.hpp) into the
// host cache (sylva/octree/brick_cache.hpp), the largest projected voxels first.
//
//   HostBrickCache cache(256 << 20);
//   BrickLoader loader(source, cache);
//   loader.submit({{key, priority}, ...});   // each frame: replaces what is still queued
//   ... cache.copy_to(key, out) once it has arrived ...
//
// submit() replaces the queue: a request the new list does not repeat is stale (the view moved
// on) and is cancelled unless its read has started. Bricks the source reports missing or corrupt
// are not cached: take_failures() hands them to the refinement once each, which then draws the
// parent instead (issue 13, faults). The destructor stops the thread after the read in flight.
#ifndef SYLVA_OCTREE_LOADER_HPP
#define SYLVA_OCTREE_LOADER_HPP

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <stop_token>
#include <thread>
#include <unordered_set>
#include <utility>
#include <vector>

#include "sylva/octree/brick_cache.hpp"
#include "sylva/octree/brick_source.hpp"

namespace sylva::octree {

/// One brick the refinement wants: larger priority first (the projected voxel size of the node
/// that waits for it, section 5's priority).
struct BrickRequest {
    std::uint32_t key = 0;
    float priority = 0.0f;
};

/// Counters of a BrickLoader (cumulative).
struct LoaderCounters {
    std::uint64_t loaded = 0;     ///< bricks read and cached
    std::uint64_t cancelled = 0;  ///< queued requests dropped by a later submit()
    std::uint64_t failed = 0;     ///< reads that returned missing or corrupt
    std::uint64_t skipped = 0;    ///< requests for bricks already cached when their turn came
};

/// Reads requested bricks from `S` into a HostBrickCache on its own thread.
template <BrickSource S>
class BrickLoader {
public:
    /// `source` and `cache` must outlive the loader. brick_words: index word 8.
    BrickLoader(const S& source, HostBrickCache& cache)
        : source_(source), cache_(cache), brick_words_(source.index().size() > 8 ? source.index()[8] : 0u),
          thread_([this](std::stop_token st) { run(st); }) {}
    ~BrickLoader() {
        thread_.request_stop();
        wake_.notify_all();
    }
    BrickLoader(const BrickLoader&) = delete;
    BrickLoader& operator=(const BrickLoader&) = delete;

    /// Replaces the queued requests by `requests` (duplicates keep their largest priority);
    /// queued keys not among them are cancelled.
    void submit(std::vector<BrickRequest> requests) {
        std::sort(requests.begin(), requests.end(), [](const BrickRequest& a, const BrickRequest& b) {
            return a.key != b.key ? a.key < b.key : a.priority > b.priority;
        });
        requests.erase(std::unique(requests.begin(), requests.end(),
                                   [](const BrickRequest& a, const BrickRequest& b) { return a.key == b.key; }),
                       requests.end());
        std::sort(requests.begin(), requests.end(), [](const BrickRequest& a, const BrickRequest& b) {
            return a.priority != b.priority ? a.priority < b.priority : a.key > b.key;  // the best last
        });
        {
            std::lock_guard lock(mutex_);
            std::unordered_set<std::uint32_t> wanted;
            for (const BrickRequest& r : requests) wanted.insert(r.key);
            for (const BrickRequest& r : queue_) counters_.cancelled += wanted.count(r.key) ? 0u : 1u;
            queue_ = std::move(requests);
        }
        wake_.notify_all();
    }
    /// Keys whose read returned missing or corrupt since the last call, with the status.
    std::vector<std::pair<std::uint32_t, BrickStatus>> take_failures() {
        std::lock_guard lock(mutex_);
        return std::exchange(failures_, {});
    }
    /// Blocks until the queue is empty and no read is in flight (tests, benchmarks' cold runs).
    void wait_idle() {
        std::unique_lock lock(mutex_);
        idle_.wait(lock, [&] { return queue_.empty() && !busy_; });
    }
    /// Requests still queued.
    [[nodiscard]] std::size_t queued() const {
        std::lock_guard lock(mutex_);
        return queue_.size();
    }
    [[nodiscard]] LoaderCounters counters() const {
        std::lock_guard lock(mutex_);
        return counters_;
    }

private:
    void run(std::stop_token st) {
        std::vector<std::uint32_t> buf(brick_words_);
        std::unique_lock lock(mutex_);
        while (!st.stop_requested()) {
            wake_.wait(lock, st, [&] { return !queue_.empty(); });
            if (st.stop_requested()) break;
            BrickRequest r = queue_.back();
            queue_.pop_back();
            busy_ = true;
            lock.unlock();
            read_one(r.key, buf);
            lock.lock();
            busy_ = false;
            if (queue_.empty()) idle_.notify_all();
        }
        busy_ = false;
        idle_.notify_all();
    }

    /// Reads one brick (no lock held but around the counters) into the cache.
    void read_one(std::uint32_t key, std::vector<std::uint32_t>& buf) {
        if (cache_.contains(key)) {
            std::lock_guard lock(mutex_);
            ++counters_.skipped;
            return;
        }
        buf.assign(brick_words_, 0u);
        BrickStatus s = source_.read_brick(key, buf);
        if (s == BrickStatus::ok) cache_.put(key, buf);
        std::lock_guard lock(mutex_);
        if (s == BrickStatus::ok) {
            ++counters_.loaded;
        } else {
            ++counters_.failed;
            failures_.emplace_back(key, s);
        }
    }

    const S& source_;
    HostBrickCache& cache_;
    std::uint32_t brick_words_;
    mutable std::mutex mutex_;
    std::condition_variable_any wake_;
    std::condition_variable_any idle_;
    std::vector<BrickRequest> queue_;  ///< the best request last
    bool busy_ = false;
    LoaderCounters counters_;
    std::vector<std::pair<std::uint32_t, BrickStatus>> failures_;
    std::jthread thread_;  ///< last member: starts after the others exist, joins before they go
};

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_LOADER_HPP
