#include <catch2/catch.hpp>

#include <atomic>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <functional>
#include <chrono>

#include <sylva/core/executor.hpp>
#include <sylva/core/progress.hpp>

using namespace sylva;

TEST_CASE("parallel_for covers the range exactly once", "[executor]") {
    ThreadPool pool(3);
    std::vector<std::atomic<int>> hits(10007);
    pool.parallel_for(0, hits.size(), 13, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) hits[i]++;
    });
    for (auto& h : hits) REQUIRE(h.load() == 1);
}

TEST_CASE("parallel_take hands out every block once, in blocks of its size, on any executor", "[executor]") {
    // The renderers' row loop: blocks of `block` items from a shared counter. Each block comes
    // once, starts at a multiple of the block from begin, and only the last one is shorter.
    auto check = [](auto& exec, std::size_t begin, std::size_t end, std::size_t block) {
        INFO("range [" << begin << ", " << end << "), block " << block << ", " << exec.concurrency() << " threads");
        std::vector<std::atomic<int>> hits(end + 1);
        std::atomic<std::size_t> calls{0}, short_blocks{0}, bad_blocks{0};  // Catch's macros on this thread only
        const std::size_t b = block == 0 ? 1 : block;
        parallel_take(exec, begin, end, block, [&](std::size_t lo, std::size_t hi) {
            ++calls;
            if (!(lo < hi && (lo - begin) % b == 0 && hi <= end)) ++bad_blocks;
            if (hi - lo != b) {
                ++short_blocks;
                if (hi != end) ++bad_blocks;
            }
            for (std::size_t i = lo; i < hi && i <= end; ++i) hits[i]++;
        });
        for (std::size_t i = 0; i <= end; ++i) REQUIRE(hits[i].load() == (i >= begin && i < end ? 1 : 0));
        CHECK(calls.load() == (end > begin ? (end - begin + b - 1) / b : 0));
        CHECK(short_blocks.load() <= 1);
        CHECK(bad_blocks.load() == 0);
    };
    ThreadPool pool(3);
    SerialExecutor serial;
    for (std::size_t end : {0, 1, 2, 7, 512, 1001})
        for (std::size_t block : {0, 1, 2, 5, 2000}) {
            check(pool, 0, end, block);
            check(serial, 0, end, block);
            check(pool, 3, end + 3, block);
        }
    check(pool, 9, 4, 2);  // an empty range: no call
    // An exception from a block reaches the caller once every task has stopped; the pool works on.
    std::atomic<int> after{0};
    CHECK_THROWS_AS(parallel_take(pool, 0, 1000, 1,
                                  [&](std::size_t lo, std::size_t) {
                                      if (lo == 500) throw std::runtime_error("block 500");
                                  }),
                    std::runtime_error);
    parallel_take(pool, 0, 100, 3, [&](std::size_t lo, std::size_t hi) { after += int(hi - lo); });
    CHECK(after.load() == 100);
}

TEST_CASE("nested invoke does not deadlock and exceptions propagate", "[executor]") {
    // Without polling, with the default, and polling longer than any wait here (every wait then
    // ends in the poll, never on the condition variable).
    const auto spin = GENERATE(std::chrono::microseconds{0}, ThreadPool::kDefaultSpin, std::chrono::microseconds{2000000});
    ThreadPool pool(2, spin);
    std::function<long(int)> fib = [&](int n) -> long {
        if (n < 2) return n;
        long a = 0, b = 0;
        pool.invoke([&] { a = fib(n - 1); }, [&] { b = fib(n - 2); });
        return a + b;
    };
    CHECK(fib(18) == 2584);
    CHECK_THROWS_AS(pool.invoke([] {}, [] { throw std::runtime_error("boom"); }), std::runtime_error);
    CHECK_THROWS_AS(pool.parallel_for(0, 100, 1, [](std::size_t lo, std::size_t) { if (lo > 50) throw std::runtime_error("x"); }),
                    std::runtime_error);
}

TEST_CASE("the progress bar stays silent for quick work and draws for slow work", "[progress]") {
    std::FILE* f = std::tmpfile();
    {
        ProgressBar quick("quick", f);
        quick.update(0.5);
        CHECK_FALSE(quick.shown());
    }
    {
        ProgressBar slow("slow", f, std::chrono::milliseconds(0));
        slow.update(0.5);
        CHECK(slow.shown());
    }
    std::rewind(f);
    char buf[256] = {};
    std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
    std::fclose(f);
    std::string out(buf, n);
    CHECK(out.find("slow") != std::string::npos);
    CHECK(out.find("100%") != std::string::npos);
    CHECK(out.find("quick") == std::string::npos);
}

TEST_CASE("parallel_for's chunks cover ranges of every size exactly once, nested inside invoke", "[executor]") {
    ThreadPool pool(4);
    for (std::size_t n : {1u, 2u, 3u, 7u, 64u, 1000u, 4099u}) {
        for (std::size_t grain : {1u, 5u, 100u}) {
            std::vector<std::atomic<int>> a(n), b(n);
            std::atomic<int> empty_chunks{0};  // counted, not REQUIREd: Catch2's assertions are not thread-safe
            auto fill = [&](std::vector<std::atomic<int>>& v) {
                pool.parallel_for(0, n, grain, [&](std::size_t lo, std::size_t hi) {
                    if (!(lo < hi)) empty_chunks++;
                    for (std::size_t i = lo; i < hi; ++i) v[i]++;
                });
            };
            pool.invoke([&] { fill(a); }, [&] { fill(b); });
            REQUIRE(empty_chunks.load() == 0);
            for (std::size_t i = 0; i < n; ++i) {
                REQUIRE(a[i].load() == 1);
                REQUIRE(b[i].load() == 1);
            }
        }
    }
}

TEST_CASE("after an exception every chunk has finished and the pool keeps working", "[executor]") {
    ThreadPool pool(3);
    for (int round = 0; round < 50; ++round) {
        std::atomic<int> running{0}, started{0}, ended{0};
        struct Running {
            std::atomic<int>& n;
            std::atomic<int>& ended;
            ~Running() {
                n--;
                ended++;
            }
        };
        CHECK_THROWS_AS(pool.parallel_for(0, 64, 1,
                                          [&](std::size_t lo, std::size_t) {
                                              running++;
                                              started++;
                                              Running guard{running, ended};
                                              std::this_thread::sleep_for(std::chrono::microseconds(50));
                                              if (lo == 0) throw std::runtime_error("chunk");
                                          }),
                        std::runtime_error);
        // No chunk still runs once parallel_for has returned (the caller's stack is gone),
        // and every chunk ran: the others are not abandoned by the throw.
        CHECK(running.load() == 0);
        CHECK(ended.load() == started.load());
        CHECK(started.load() == 11);  // chunks of ceil(64 / min(64, 4 * concurrency())) = 6
    }
    std::atomic<long> sum{0};
    pool.parallel_for(0, 1000, 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) sum += long(i);
    });
    CHECK(sum.load() == 999L * 1000L / 2L);
}

TEST_CASE("deeply nested invokes and parallel_fors from every thread finish", "[executor]") {
    const auto spin = GENERATE(std::chrono::microseconds{0}, ThreadPool::kDefaultSpin, std::chrono::microseconds{2000000});
    ThreadPool pool(2, spin);
    std::atomic<long> leaves{0};
    std::function<void(int)> tree = [&](int depth) {
        if (depth == 0) {
            leaves++;
            return;
        }
        pool.parallel_for(0, 3, 1, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t i = lo; i < hi; ++i) pool.invoke([&] { tree(depth - 1); }, [&] { tree(depth - 1); });
        });
    };
    tree(4);
    CHECK(leaves.load() == 1296);  // (3 * 2)^4
}

TEST_CASE("a pool that polls for minutes still hands out work, and stops without waiting its polls out", "[executor]") {
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    {
        ThreadPool pool(3, std::chrono::minutes(10));
        for (int round = 0; round < 20; ++round) {
            std::atomic<int> chunks{0};
            pool.parallel_for(0, 12, 1, [&](std::size_t, std::size_t) {
                std::this_thread::sleep_for(std::chrono::microseconds(200));
                chunks++;
            });
            REQUIRE(chunks.load() == 12);
            // A pause longer than the tasks: the workers are polling an empty queue now.
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
    }  // the destructor: its workers stop polling when told to stop
    CHECK(Clock::now() - start < std::chrono::minutes(1));
}

namespace {
/// Whether every thread of `pool` runs a chunk of one parallel_for at the same time: each chunk
/// waits (up to 5 s) until all of them have started, so that a worker that has left its loop
/// (or never wakes) shows as a chunk that waited in vain.
bool all_threads_run_together(ThreadPool& pool) {
    const std::size_t n = pool.concurrency();
    std::atomic<std::size_t> started{0}, met{0};
    pool.parallel_for(0, n, 1, [&](std::size_t, std::size_t) {
        started++;
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (started.load() < n && std::chrono::steady_clock::now() < until) std::this_thread::yield();
        if (started.load() >= n) met++;
    });
    return met.load() == n;
}
template <class X>
concept HasWakeHook = requires(X& x) { x.wake_workers(); };
}  // namespace

TEST_CASE("wake_workers leaves the workers working, asleep or polling, and the pool stops", "[executor]") {
    for (auto spin : {std::chrono::microseconds(0), std::chrono::microseconds(200), std::chrono::microseconds(600000000)}) {
        ThreadPool pool(3, spin);
        for (int round = 0; round < 10; ++round) {
            pool.wake_workers();  // with nothing queued: the workers poll, then block again
            if (round % 3 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
            pool.wake_workers();
            REQUIRE(all_threads_run_together(pool));
        }
        pool.wake_workers();  // a hint just before the destructor: it must still stop
    }
    STATIC_REQUIRE(HasWakeHook<ThreadPool>);
    STATIC_REQUIRE(!HasWakeHook<SerialExecutor>);  // no hook: bih::build calls it only where there is one
}
