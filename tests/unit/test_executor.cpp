#include <catch2/catch.hpp>

#include <atomic>
#include <numeric>
#include <stdexcept>

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

TEST_CASE("nested invoke does not deadlock and exceptions propagate", "[executor]") {
    ThreadPool pool(2);
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
