// sylva/octree/lru.hpp -- the two replacement policies of the out-of-core octree (Gobbetti,
// Marton, Iglesias Guitian, section 5: "Both memory pools are managed using a LRU policy"):
//
//  * LruCache<V>: values keyed by brick key, each with a size in bytes, under a byte budget; an
//    insert evicts least recently used entries until the new one fits (the host's level-2 cache
//    of decompressed bricks, sylva/octree/brick_cache.hpp);
//  * SlotPool: a fixed number of equal slots (the device's brick pool: a storage buffer of
//    `slots` bricks), a key per occupied slot, replacement of the least recently used slot that
//    is not pinned (the bricks the current frame draws are pinned: never replaced while in use).
//
// Neither is thread-safe; the callers lock (brick_cache.hpp) or use them from one thread
// (residency.hpp). Every operation is O(1) but SlotPool::assign, which skips pinned slots from
// the least recently used end (pinned slots are touched when pinned, so they sit at the other).
#ifndef SYLVA_OCTREE_LRU_HPP
#define SYLVA_OCTREE_LRU_HPP

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <list>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"

namespace sylva::octree {

/// Values keyed by 32-bit keys under a byte budget, least recently used evicted first.
template <class V>
class LruCache {
public:
    explicit LruCache(std::size_t budget_bytes) : budget_(budget_bytes) {}

    /// The value of `key` (made the most recently used), or nullptr.
    V* find(std::uint32_t key) {
        auto it = map_.find(key);
        if (it == map_.end()) return nullptr;
        order_.splice(order_.begin(), order_, it->second);
        return &it->second->value;
    }
    /// The value of `key` without touching it, or nullptr.
    [[nodiscard]] const V* peek(std::uint32_t key) const {
        auto it = map_.find(key);
        return it == map_.end() ? nullptr : &it->second->value;
    }
    [[nodiscard]] bool contains(std::uint32_t key) const { return map_.count(key) != 0; }

    /// Inserts (or replaces) `key` as the most recently used entry of `bytes` bytes, evicting
    /// least recently used entries until the total fits the budget; their keys are appended to
    /// `evicted` when given. An entry larger than the whole budget is not inserted (false).
    bool insert(std::uint32_t key, V value, std::size_t bytes, std::vector<std::uint32_t>* evicted = nullptr) {
        if (bytes > budget_) return false;
        erase(key);
        while (bytes_ + bytes > budget_) {
            Entry& last = order_.back();
            if (evicted) evicted->push_back(last.key);
            bytes_ -= last.bytes;
            map_.erase(last.key);
            order_.pop_back();
        }
        order_.push_front(Entry{key, bytes, std::move(value)});
        map_.emplace(key, order_.begin());
        bytes_ += bytes;
        return true;
    }
    /// Removes `key`; false when absent.
    bool erase(std::uint32_t key) {
        auto it = map_.find(key);
        if (it == map_.end()) return false;
        bytes_ -= it->second->bytes;
        order_.erase(it->second);
        map_.erase(it);
        return true;
    }

    [[nodiscard]] std::size_t bytes() const { return bytes_; }
    [[nodiscard]] std::size_t budget() const { return budget_; }
    [[nodiscard]] std::size_t size() const { return map_.size(); }
    /// Keys from the most to the least recently used (tests compare it with a reference model).
    [[nodiscard]] std::vector<std::uint32_t> keys() const {
        std::vector<std::uint32_t> k;
        for (const Entry& e : order_) k.push_back(e.key);
        return k;
    }

private:
    struct Entry {
        std::uint32_t key;
        std::size_t bytes;
        V value;
    };
    std::size_t budget_;
    std::size_t bytes_ = 0;
    std::list<Entry> order_;  ///< most recently used first
    std::unordered_map<std::uint32_t, typename std::list<Entry>::iterator> map_;
};

/// A fixed number of slots holding one key each, the least recently used unpinned slot
/// replaced first.
class SlotPool {
public:
    explicit SlotPool(std::uint32_t slots) : key_of_(slots, kFree), pinned_(slots, 0u), where_(slots) {
        for (std::uint32_t s = slots; s-- > 0;) free_.push_back(s);
    }

    [[nodiscard]] std::uint32_t slots() const { return static_cast<std::uint32_t>(key_of_.size()); }
    [[nodiscard]] std::uint32_t used() const { return slots() - static_cast<std::uint32_t>(free_.size()); }
    [[nodiscard]] std::uint32_t pinned_count() const { return pinned_total_; }
    /// The slot holding `key`, if any (no touch).
    [[nodiscard]] std::optional<std::uint32_t> find(std::uint32_t key) const {
        auto it = slot_of_.find(key);
        if (it == slot_of_.end()) return std::nullopt;
        return it->second;
    }
    /// The key in `slot` (kFree when empty).
    [[nodiscard]] std::uint32_t key_in(std::uint32_t slot) const { return key_of_.at(slot); }
    /// Makes `slot` the most recently used.
    void touch(std::uint32_t slot) {
        if (key_of_.at(slot) == kFree) return;
        order_.splice(order_.begin(), order_, where_[slot]);
    }
    /// A slot for `key`: a free one, else the least recently used unpinned one (its key is
    /// written to `evicted`); nullopt when every slot is pinned. The slot is the most recently
    /// used afterwards. Throws when `key` already has a slot.
    std::optional<std::uint32_t> assign(std::uint32_t key, std::uint32_t& evicted) {
        evicted = kFree;
        if (slot_of_.count(key)) throw Error("SlotPool: key " + std::to_string(key) + " already has a slot");
        std::uint32_t slot;
        if (!free_.empty()) {
            slot = free_.back();
            free_.pop_back();
        } else {
            auto it = order_.end();
            while (it != order_.begin()) {
                --it;
                if (!pinned_[*it]) break;
            }
            if (order_.empty() || pinned_[*it]) return std::nullopt;
            slot = *it;
            evicted = key_of_[slot];
            slot_of_.erase(evicted);
            order_.erase(it);
        }
        key_of_[slot] = key;
        slot_of_.emplace(key, slot);
        order_.push_front(slot);
        where_[slot] = order_.begin();
        return slot;
    }
    /// Empties the slot of `key` (a brick found bad); false when absent.
    bool release(std::uint32_t key) {
        auto it = slot_of_.find(key);
        if (it == slot_of_.end()) return false;
        std::uint32_t slot = it->second;
        unpin(slot);
        order_.erase(where_[slot]);
        key_of_[slot] = kFree;
        slot_of_.erase(it);
        free_.push_back(slot);
        return true;
    }
    void pin(std::uint32_t slot) {
        if (!pinned_.at(slot)) ++pinned_total_;
        pinned_[slot] = 1u;
        touch(slot);
    }
    void unpin(std::uint32_t slot) {
        if (pinned_.at(slot)) --pinned_total_;
        pinned_[slot] = 0u;
    }
    [[nodiscard]] bool pinned(std::uint32_t slot) const { return pinned_.at(slot) != 0u; }
    void unpin_all() {
        std::fill(pinned_.begin(), pinned_.end(), 0u);
        pinned_total_ = 0;
    }
    /// Occupied slots from the most to the least recently used (tests).
    [[nodiscard]] std::vector<std::uint32_t> order() const { return {order_.begin(), order_.end()}; }

    static constexpr std::uint32_t kFree = 0xFFFFFFFFu;

private:
    std::vector<std::uint32_t> key_of_;
    std::vector<std::uint8_t> pinned_;
    std::uint32_t pinned_total_ = 0;
    std::list<std::uint32_t> order_;  ///< occupied slots, most recently used first
    std::vector<std::list<std::uint32_t>::iterator> where_;
    std::unordered_map<std::uint32_t, std::uint32_t> slot_of_;
    std::vector<std::uint32_t> free_;
};

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_LRU_HPP
