// The asynchronous loader (sylva/octree/loader.hpp) and the host cache
// (sylva/octree/brick_cache.hpp) under concurrent use: several threads submit, read the cache
// and take failures while the loader thread reads; every brick that arrives equals the source's,
// the cache stays within its budget, stale requests are cancelled, bad bricks are handed over
// once. Run these under ThreadSanitizer (tests/residency/CMakeLists.txt).
#include <catch2/catch.hpp>

#include <atomic>
#include <random>
#include <thread>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/loader.hpp>

#include "fault_source.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace residency_test;

TEST_CASE("loader: concurrent submitters and readers get the source's bricks, within the budget", "[loader][concurrency]") {
    octree::Tree t = octree::build(octree_test::blobs({40, 36, 30}, 3), {4, 1});
    const std::uint32_t words = t.brick_words(), count = std::uint32_t(t.brick_count());
    FaultySource src(t, {}, {}, std::chrono::microseconds(20));
    const std::size_t budget = std::size_t{words} * 4 * 50;  // 50 of the source's bricks
    octree::HostBrickCache cache(budget);
    std::atomic<std::uint64_t> mismatches{0}, hits{0}, over_budget{0};  // Catch2 asserts on this thread only
    {
        octree::BrickLoader loader(src, cache);
        std::vector<std::jthread> threads;
        for (std::uint32_t th = 0; th < 4; ++th)
            threads.emplace_back([&, th] {
                std::mt19937 rng(th + 1);
                std::vector<std::uint32_t> out(words);
                for (int round = 0; round < 200; ++round) {
                    std::vector<octree::BrickRequest> req;
                    for (int i = 0; i < 16; ++i) req.push_back({std::uint32_t(rng() % std::min(count, 150u)), float(rng() % 100)});
                    loader.submit(req);
                    for (const auto& r : req)
                        if (cache.copy_to(r.key, out)) {
                            ++hits;
                            if (!std::equal(out.begin(), out.end(), t.bricks.begin() + std::ptrdiff_t(std::size_t{r.key} * words)))
                                ++mismatches;
                        }
                    if (cache.counters().bytes > budget) ++over_budget;
                    (void)loader.take_failures();
                    std::this_thread::sleep_for(std::chrono::microseconds(300));
                }
            });
        threads.clear();
        loader.wait_idle();
        octree::LoaderCounters c = loader.counters();
        CHECK(c.loaded > 50);
        CHECK(c.cancelled > 0);  // requests replaced before their turn
        CHECK(c.failed == 0);
    }
    CHECK(mismatches == 0);
    CHECK(over_budget == 0);
    CHECK(hits > 0);
    CHECK(cache.counters().peak_bytes <= budget);
    CHECK(cache.counters().evicted > 0);
}

TEST_CASE("loader: the best priority is read first, stale requests are dropped", "[loader][concurrency]") {
    octree::Tree t = octree::build(octree_test::blobs({32, 32, 32}, 4), {4, 1});
    FaultySource src(t);
    octree::HostBrickCache cache(std::size_t{1} << 30);
    octree::BrickLoader loader(src, cache);
    // The loader thread parks inside the read of brick 1 while both lists are submitted (no
    // race with its reads, however the threads are scheduled).
    src.hold(1);
    loader.submit({{1, 1.0f}});
    src.wait_entered();
    std::vector<octree::BrickRequest> req;
    for (std::uint32_t k = 2; k < 40; ++k) req.push_back({k, float(k)});
    loader.submit(req);
    loader.submit({{39, 5.0f}, {2, 9.0f}});  // all but two become stale
    src.release();
    loader.wait_idle();
    CHECK(cache.contains(1));
    CHECK(cache.contains(2));
    CHECK(cache.contains(39));
    std::uint32_t others = 0;
    for (std::uint32_t k = 3; k < 39; ++k) others += cache.contains(k) ? 1u : 0u;
    CHECK(others == 0);
    CHECK(loader.counters().cancelled == 36);
    CHECK(src.read_order() == std::vector<std::uint32_t>{1, 2, 39});  // the best (9) before 39 (5)
}

TEST_CASE("loader: missing and corrupt bricks are handed over once and not cached", "[loader][concurrency]") {
    octree::Tree t = octree::build(octree_test::blobs({32, 32, 32}, 5), {4, 1});
    FaultySource src(t, {3, 7}, {5});
    octree::HostBrickCache cache(std::size_t{1} << 30);
    octree::BrickLoader loader(src, cache);
    loader.submit({{3, 1.0f}, {5, 1.0f}, {7, 1.0f}, {8, 1.0f}});
    loader.wait_idle();
    auto failures = loader.take_failures();
    std::sort(failures.begin(), failures.end());
    REQUIRE(failures.size() == 3);
    CHECK(failures[0] == std::pair{3u, octree::BrickStatus::corrupt});
    CHECK(failures[1] == std::pair{5u, octree::BrickStatus::missing});
    CHECK(failures[2] == std::pair{7u, octree::BrickStatus::corrupt});
    CHECK(loader.take_failures().empty());
    CHECK_FALSE(cache.contains(3));
    CHECK_FALSE(cache.contains(5));
    CHECK(cache.contains(8));
}
