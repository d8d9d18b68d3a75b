// A BrickSource for the residency tests: the in-core tree (TreeBrickSource) with injected
// faults: chosen keys read as missing or corrupt, every read delayed, reads counted per key.
#ifndef SYLVA_TESTS_RESIDENCY_FAULT_SOURCE_HPP
#define SYLVA_TESTS_RESIDENCY_FAULT_SOURCE_HPP

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
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

    octree::BrickStatus read_brick(std::uint32_t key, std::span<std::uint32_t> out) const {
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

private:
    octree::TreeBrickSource inner_;
    std::set<std::uint32_t> corrupt_, missing_;
    std::chrono::microseconds delay_;
    std::unique_ptr<std::atomic<std::uint32_t>[]> reads_;
};

static_assert(octree::BrickSource<FaultySource>);

}  // namespace residency_test

#endif
