// LruCache and SlotPool (sylva/octree/lru.hpp) against reference models driven by random
// operation sequences; the byte budget and the slot count are checked after every operation.
#include <catch2/catch.hpp>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include <sylva/octree/lru.hpp>

using namespace sylva::octree;

namespace {

/// The reference: a vector of (key, bytes, value), most recently used first.
struct ModelLru {
    struct E {
        std::uint32_t key;
        std::size_t bytes;
        int value;
    };
    std::size_t budget;
    std::vector<E> order;
    std::size_t bytes() const {
        std::size_t b = 0;
        for (const E& e : order) b += e.bytes;
        return b;
    }
    int* find(std::uint32_t k) {
        auto it = std::find_if(order.begin(), order.end(), [&](const E& e) { return e.key == k; });
        if (it == order.end()) return nullptr;
        std::rotate(order.begin(), it, it + 1);
        return &order.front().value;
    }
    void erase(std::uint32_t k) {
        order.erase(std::remove_if(order.begin(), order.end(), [&](const E& e) { return e.key == k; }), order.end());
    }
    bool insert(std::uint32_t k, int v, std::size_t b, std::vector<std::uint32_t>& evicted) {
        if (b > budget) return false;
        erase(k);
        while (bytes() + b > budget) {
            evicted.push_back(order.back().key);
            order.pop_back();
        }
        order.insert(order.begin(), E{k, b, v});
        return true;
    }
    std::vector<std::uint32_t> keys() const {
        std::vector<std::uint32_t> k;
        for (const E& e : order) k.push_back(e.key);
        return k;
    }
};

}  // namespace

TEST_CASE("LruCache equals the reference model on random operations and never exceeds its budget", "[lru]") {
    for (std::uint32_t seed = 1; seed <= 20; ++seed) {
        std::mt19937 rng(seed);
        std::size_t budget = 50 + rng() % 400;
        LruCache<int> lru(budget);
        ModelLru model{budget, {}};
        for (int op = 0; op < 3000; ++op) {
            std::uint32_t key = rng() % 40;
            switch (rng() % 4) {
                case 0:
                case 1: {
                    std::size_t bytes = 1 + rng() % (budget / 3 + 20);  // sometimes over the budget
                    int value = static_cast<int>(rng());
                    std::vector<std::uint32_t> e1, e2;
                    bool a = lru.insert(key, value, bytes, &e1);
                    bool b = model.insert(key, value, bytes, e2);
                    REQUIRE(a == b);
                    REQUIRE(e1 == e2);
                    break;
                }
                case 2: {
                    int* a = lru.find(key);
                    int* b = model.find(key);
                    REQUIRE((a == nullptr) == (b == nullptr));
                    if (a) REQUIRE(*a == *b);
                    break;
                }
                default: {
                    std::vector<std::uint32_t> keys = model.keys();
                    REQUIRE(lru.erase(key) == (std::find(keys.begin(), keys.end(), key) != keys.end()));
                    model.erase(key);
                }
            }
            REQUIRE(lru.bytes() <= budget);
            REQUIRE(lru.bytes() == model.bytes());
            REQUIRE(lru.keys() == model.keys());
        }
    }
}

TEST_CASE("SlotPool replaces the least recently used unpinned slot and never a pinned one", "[lru]") {
    for (std::uint32_t seed = 1; seed <= 20; ++seed) {
        std::mt19937 rng(seed);
        std::uint32_t slots = 1 + rng() % 12;
        SlotPool pool(slots);
        // The model: keys by slot, a recency list of slots (most recent first), pinned flags.
        std::vector<std::uint32_t> key_of(slots, SlotPool::kFree);
        std::vector<std::uint32_t> recency;
        std::vector<bool> pinned(slots, false);
        std::vector<std::uint32_t> free_stack;  // free slots are reused last freed first
        for (std::uint32_t s = slots; s-- > 0;) free_stack.push_back(s);
        auto touch = [&](std::uint32_t s) {
            recency.erase(std::remove(recency.begin(), recency.end(), s), recency.end());
            recency.insert(recency.begin(), s);
        };
        for (int op = 0; op < 3000; ++op) {
            std::uint32_t key = rng() % 30;
            auto held = std::find(key_of.begin(), key_of.end(), key);
            switch (rng() % 5) {
                case 0:
                case 1: {
                    if (held != key_of.end()) break;
                    std::uint32_t evicted;
                    auto got = pool.assign(key, evicted);
                    if (!free_stack.empty()) {
                        REQUIRE(got);
                        REQUIRE(*got == free_stack.back());
                        free_stack.pop_back();
                        REQUIRE(evicted == SlotPool::kFree);
                    } else {
                        std::optional<std::uint32_t> victim;
                        for (auto it = recency.rbegin(); it != recency.rend(); ++it)
                            if (!pinned[*it]) {
                                victim = *it;
                                break;
                            }
                        REQUIRE(got.has_value() == victim.has_value());
                        if (!got) break;
                        REQUIRE(*got == *victim);
                        REQUIRE(evicted == key_of[*victim]);
                    }
                    key_of[*got] = key;
                    touch(*got);
                    break;
                }
                case 2:
                    if (held != key_of.end()) {
                        std::uint32_t s = std::uint32_t(held - key_of.begin());
                        pool.pin(s);
                        pinned[s] = true;
                        touch(s);
                    }
                    break;
                case 3:
                    if (rng() % 4 == 0) {
                        pool.unpin_all();
                        std::fill(pinned.begin(), pinned.end(), false);
                    } else if (held != key_of.end()) {
                        std::uint32_t s = std::uint32_t(held - key_of.begin());
                        pool.touch(s);
                        touch(s);
                    }
                    break;
                default:
                    REQUIRE(pool.release(key) == (held != key_of.end()));
                    if (held != key_of.end()) {
                        std::uint32_t s = std::uint32_t(held - key_of.begin());
                        *held = SlotPool::kFree;
                        pinned[s] = false;
                        free_stack.push_back(s);
                        recency.erase(std::remove(recency.begin(), recency.end(), s), recency.end());
                    }
            }
            REQUIRE(pool.used() <= slots);
            REQUIRE(pool.order() == recency);
            for (std::uint32_t s = 0; s < slots; ++s) {
                REQUIRE(pool.key_in(s) == key_of[s]);
                REQUIRE(pool.pinned(s) == pinned[s]);
                if (key_of[s] != SlotPool::kFree) REQUIRE(pool.find(key_of[s]) == std::optional<std::uint32_t>(s));
            }
            REQUIRE(pool.pinned_count() == std::uint32_t(std::count(pinned.begin(), pinned.end(), true)));
        }
    }
}
