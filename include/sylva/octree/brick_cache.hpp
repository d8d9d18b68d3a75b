// sylva/octree/brick_cache.hpp -- the host's cache of decompressed bricks (Gobbetti, Marton,
// Iglesias Guitian, section 5: "the CPU cache being used as a larger level-2 cache that uses
// system memory to avoid disk accesses for recently used blocks"): an LRU cache
// (sylva/octree/lru.hpp) under a byte budget, shared by the loader thread, which fills it, and
// the refinement, which copies bricks out of it into the device pool. Every member function is
// thread-safe (one mutex; a copy out of the cache is one brick, ~190 KB for 32^3 bricks with a
// border of 2).
#ifndef SYLVA_OCTREE_BRICK_CACHE_HPP
#define SYLVA_OCTREE_BRICK_CACHE_HPP

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "sylva/octree/lru.hpp"

namespace sylva::octree {

/// Counters of a HostBrickCache (cumulative).
struct HostCacheCounters {
    std::uint64_t hits = 0;       ///< copy_to found the brick
    std::uint64_t misses = 0;     ///< copy_to did not
    std::uint64_t inserted = 0;   ///< bricks put
    std::uint64_t evicted = 0;    ///< bricks dropped to stay within the budget
    std::size_t bytes = 0;        ///< bytes held now (sum of the bricks' sizes)
    std::size_t peak_bytes = 0;   ///< most bytes ever held
};

/// Decompressed bricks on the host, LRU under a byte budget; thread-safe.
class HostBrickCache {
public:
    explicit HostBrickCache(std::size_t budget_bytes) : lru_(budget_bytes) {}

    /// Copies brick `key` into `out` (exactly its size) and makes it the most recently used;
    /// false (a miss) when absent or of another size.
    bool copy_to(std::uint32_t key, std::span<std::uint32_t> out) {
        std::lock_guard lock(mutex_);
        const std::vector<std::uint32_t>* b = lru_.find(key);
        if (!b || b->size() != out.size()) {
            ++counters_.misses;
            return false;
        }
        std::copy(b->begin(), b->end(), out.begin());
        ++counters_.hits;
        return true;
    }
    /// True when `key` is held (no touch, no counting).
    [[nodiscard]] bool contains(std::uint32_t key) const {
        std::lock_guard lock(mutex_);
        return lru_.contains(key);
    }
    /// Stores brick `key` as the most recently used, evicting others to stay within the budget;
    /// false when one brick exceeds the whole budget (nothing stored).
    bool put(std::uint32_t key, std::vector<std::uint32_t> brick) {
        std::size_t bytes = brick.size() * sizeof(std::uint32_t);
        std::lock_guard lock(mutex_);
        std::vector<std::uint32_t> evicted;
        bool ok = lru_.insert(key, std::move(brick), bytes, &evicted);
        counters_.evicted += evicted.size();
        if (ok) ++counters_.inserted;
        counters_.bytes = lru_.bytes();
        counters_.peak_bytes = std::max(counters_.peak_bytes, counters_.bytes);
        return ok;
    }
    [[nodiscard]] HostCacheCounters counters() const {
        std::lock_guard lock(mutex_);
        return counters_;
    }
    [[nodiscard]] std::size_t budget() const { return lru_.budget(); }

private:
    mutable std::mutex mutex_;
    LruCache<std::vector<std::uint32_t>> lru_;
    HostCacheCounters counters_;
};

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_BRICK_CACHE_HPP
