// A user's own pool behind sylva::Executor: oneTBB's task_arena. The BIH built through it must
// equal the one built by sylva's ThreadPool and on one thread (the build is deterministic
// whatever runs its tasks).
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <cstring>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_invoke.h>
#include <oneapi/tbb/task_arena.h>

#include <sylva/bih/build.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/elements/sphere.hpp>

namespace {

/// An Executor over a TBB arena of `threads` threads.
class TbbExecutor {
public:
    explicit TbbExecutor(int threads) : arena_(threads) {}
    [[nodiscard]] std::size_t concurrency() const { return std::size_t(arena_.max_concurrency()); }
    template <class F>
    void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, F&& f) {
        arena_.execute([&] {
            oneapi::tbb::parallel_for(oneapi::tbb::blocked_range<std::size_t>(begin, end, std::max<std::size_t>(grain, 1)),
                                      [&](const oneapi::tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
        });
    }
    template <class F, class G>
    void invoke(F&& f, G&& g) {
        arena_.execute([&] { oneapi::tbb::parallel_invoke(f, g); });
    }

private:
    oneapi::tbb::task_arena arena_;
};
static_assert(sylva::Executor<TbbExecutor>);

std::vector<sylva::Sphere> random_spheres(std::size_t n) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<sylva::Sphere> s(n);
    for (auto& e : s) {
        e.center = sylva::vec3(u(rng), u(rng), u(rng)) * 100.0f;
        e.radius = 0.05f + u(rng);
    }
    return s;
}

}  // namespace

TEST_CASE("a TBB task_arena is an Executor: the BIH it builds equals ThreadPool's and the serial one", "[executor][tbb]") {
    auto spheres = random_spheres(200000);
    sylva::bih::Config cfg;
    cfg.parallel_threshold = 4096;
    TbbExecutor tbb(2);
    sylva::ThreadPool pool(2);
    auto a = sylva::bih::build(std::span<const sylva::Sphere>(spheres), cfg, tbb);
    auto b = sylva::bih::build(std::span<const sylva::Sphere>(spheres), cfg, pool);
    auto c = sylva::bih::build(std::span<const sylva::Sphere>(spheres), cfg);
    REQUIRE(a.nodes.size() == c.nodes.size());
    REQUIRE(b.nodes.size() == c.nodes.size());
    CHECK(a.order == c.order);
    CHECK(b.order == c.order);
    CHECK(std::memcmp(a.nodes.data(), c.nodes.data(), c.nodes.size() * sizeof(c.nodes[0])) == 0);
    CHECK(std::memcmp(b.nodes.data(), c.nodes.data(), c.nodes.size() * sizeof(c.nodes[0])) == 0);
}
