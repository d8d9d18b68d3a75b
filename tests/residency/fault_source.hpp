// A BrickSource for the residency tests: the in-core tree (TreeBrickSource) with injected
// faults: chosen keys read as missing or corrupt, every read delayed, reads counted per key, and
// one key's read held until the test releases it (a loader thread parked at a known point, so
// that what the test submits meanwhile does not race with its reads).
#ifndef SYLVA_TESTS_RESIDENCY_FAULT_SOURCE_HPP
#define SYLVA_TESTS_RESIDENCY_FAULT_SOURCE_HPP

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <span>
#include <thread>
#include <vector>

#include <sylva/octree/brick_source.hpp>

namespace residency_test {

using namespace sylva;

class FaultySource {
public:
    explicit FaultySource(octree::Tree t, std::set<std::uint32_t> corrupt = {}, std::set<std::uint32_t> missing = {},
                          std::chrono::microseconds delay = {})
        : inner_(std::move(t)), corrupt_(std::move(corrupt)), missing_(std::move(missing)), delay_(delay),
          reads_(std::make_unique<std::atomic<std::uint32_t>[]>(inner_.tree().brick_count() + 1)) {}

    [[nodiscard]] std::span<const std::uint32_t> index() const { return inner_.index(); }
    [[nodiscard]] const octree::Tree& tree() const { return inner_.tree(); }

    /// Reads of `key` wait, once inside read_brick, until release().
    void hold(std::uint32_t key) {
        std::lock_guard lock(gate_->m);
        gate_->held = key;
        gate_->entered = false;
    }
    /// Blocks until a read of the held key has entered read_brick.
    void wait_entered() const {
        std::unique_lock lock(gate_->m);
        gate_->cv.wait(lock, [&] { return gate_->entered; });
    }
    /// Lets the held read (and later ones) go on.
    void release() {
        {
            std::lock_guard lock(gate_->m);
            gate_->held = kNoKey;
        }
        gate_->cv.notify_all();
    }

    octree::BrickStatus read_brick(std::uint32_t key, std::span<std::uint32_t> out) const {
        {
            std::unique_lock lock(gate_->m);
            gate_->order.push_back(key);
            if (gate_->held == key) {
                gate_->entered = true;
                gate_->cv.notify_all();
                gate_->cv.wait(lock, [&] { return gate_->held != key; });
            }
        }
        if (delay_.count() > 0) std::this_thread::sleep_for(delay_);
        if (key < inner_.tree().brick_count()) reads_[key].fetch_add(1, std::memory_order_relaxed);
        if (missing_.count(key)) return octree::BrickStatus::missing;
        octree::BrickStatus s = inner_.read_brick(key, out);
        if (s == octree::BrickStatus::ok && corrupt_.count(key)) {
            for (std::uint32_t& w : out) w ^= 0x5A5A5A5Au;  // what a failed checksum would have caught
            return octree::BrickStatus::corrupt;
        }
        return s;
    }
    [[nodiscard]] std::uint32_t reads(std::uint32_t key) const { return reads_[key].load(); }
    /// Every key read_brick was called with, in call order.
    [[nodiscard]] std::vector<std::uint32_t> read_order() const {
        std::lock_guard lock(gate_->m);
        return gate_->order;
    }

private:
    static constexpr std::uint32_t kNoKey = 0xFFFFFFFFu;
    struct Gate {
        std::mutex m;
        std::condition_variable cv;
        std::uint32_t held = kNoKey;
        bool entered = false;
        std::vector<std::uint32_t> order;
    };
    octree::TreeBrickSource inner_;
    std::set<std::uint32_t> corrupt_, missing_;
    std::chrono::microseconds delay_;
    std::unique_ptr<std::atomic<std::uint32_t>[]> reads_;
    std::unique_ptr<Gate> gate_ = std::make_unique<Gate>();
};

static_assert(octree::BrickSource<FaultySource>);

}  // namespace residency_test

#endif
