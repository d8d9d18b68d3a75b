#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <utility>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/core/memory.hpp>
#include <sys/mman.h>
#include <unistd.h>

using namespace sylva;

namespace {
std::uintptr_t address(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }

/// Pages of [p, p + bytes) the kernel holds in memory (mincore), of all of them.
std::pair<std::size_t, std::size_t> resident_pages(const void* p, std::size_t bytes) {
    const std::size_t page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    std::vector<unsigned char> in((bytes + page - 1) / page);
    REQUIRE(::mincore(const_cast<void*>(p), bytes, in.data()) == 0);
    return {static_cast<std::size_t>(std::count_if(in.begin(), in.end(), [](unsigned char b) { return (b & 1u) != 0; })),
            in.size()};
}
}  // namespace

TEST_CASE("large blocks are 2 MiB aligned, cached on free and reused warm", "[memory]") {
    memory::Config keep = memory::config();
    memory::configure({.cache_bytes = std::size_t{64} << 20, .huge_pages = true});
    memory::release_cache();
    const void* first = nullptr;
    {
        LargeVector<float> a(std::size_t{3} << 20);  // 12 MiB
        first = a.data();
        CHECK(address(a.data()) % memory::kHugePage == 0);
        std::iota(a.begin(), a.end(), 0.0f);
    }
    memory::Stats s0 = memory::stats();
    CHECK(s0.cached_bytes == std::size_t{12} << 20);
    {
        LargeVector<std::uint32_t> b(std::size_t{5} << 20);  // 20 MiB: too big for the 12 MiB block
        CHECK(b.data() != first);
        LargeVector<std::uint32_t> c(std::size_t{2} << 20);  // 8 MiB: fits the cached 12 MiB block
        CHECK(c.data() == first);
        CHECK(c[12345] == 0u);  // a vector still value-initialises what it reuses
    }
    memory::Stats s1 = memory::stats();
    CHECK(s1.reuses == s0.reuses + 1);
    CHECK(s1.cached_bytes == std::size_t{32} << 20);
    memory::configure({.cache_bytes = 0, .huge_pages = true});  // gives the cache back at once
    CHECK(memory::stats().cached_bytes == 0);
    CHECK(memory::stats().mapped_bytes == s1.mapped_bytes - s1.cached_bytes);
    memory::configure(keep);
}

TEST_CASE("small blocks come from operator new, 64-byte aligned; buffers do not zero", "[memory]") {
    LargeVector<char> small(100, 'x');
    CHECK(address(small.data()) % 64 == 0);
    CHECK(small[99] == 'x');
    memory::LargeBuffer<std::uint64_t> buffer(std::size_t{1} << 18);  // 2 MiB, uninitialised
    CHECK(buffer.size() == std::size_t{1} << 18);
    CHECK(address(buffer.data()) % memory::kHugePage == 0);
    buffer.data()[buffer.size() - 1] = 7;
    CHECK(buffer.data()[buffer.size() - 1] == 7u);
    memory::LargeBuffer<std::uint8_t> none(0);
    CHECK(none.data() == nullptr);
}

TEST_CASE("an absurd size is std::bad_alloc, not a wrapped small block", "[memory]") {
    memory::LargeAllocator<double> alloc;
    CHECK_THROWS_AS(alloc.allocate(SIZE_MAX / 4), std::bad_alloc);
}

TEST_CASE("the default cache holds a rebuild of the largest default BIH the benchmarks build", "[memory]") {
    // 4 GiB, at most a quarter of the physical memory, at least 256 MiB (memory.hpp). A default
    // BIH over 10^7 spheres frees 1.7 GB per rebuild; the former 1 GiB let every rebuild map
    // fresh memory.
    const std::size_t gib = std::size_t{1} << 30;
    long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    REQUIRE(pages > 0);
    const std::size_t quarter = static_cast<std::size_t>(pages) / 4 * static_cast<std::size_t>(page);
    const std::size_t want = std::max(std::min(4 * gib, quarter), std::size_t{256} << 20);
    CHECK(memory::default_cache_bytes() == want);
    CHECK(memory::Config{}.cache_bytes == want);
    if (quarter >= 2 * gib) CHECK(memory::default_cache_bytes() >= 2 * gib);  // this project's 24 GiB machines
}

TEST_CASE("prefault faults a block in on the pool and caches it for the allocation that follows", "[memory]") {
    memory::Config keep = memory::config();
    memory::configure({.cache_bytes = std::size_t{64} << 20, .huge_pages = true});
    memory::release_cache();
    ThreadPool pool(2);
    const std::size_t n = std::size_t{3} << 20;  // 12 MiB of floats
    memory::Stats s0 = memory::stats();
    memory::prefault<float>(n, pool);
    memory::Stats s1 = memory::stats();
    CHECK(s1.maps == s0.maps + 1);
    CHECK(s1.cached_bytes == std::size_t{12} << 20);
    {
        LargeVector<float> v;
        v.reserve(n);  // the prefaulted block, every page already in memory
        CHECK(memory::stats().reuses == s1.reuses + 1);
        CHECK(memory::stats().cached_bytes == 0);
        auto [resident, pages] = resident_pages(v.data(), n * sizeof(float));
        CHECK(resident == pages);
        v.resize(n);
        CHECK(v[n - 1] == 0.0f);  // the vector still value-initialises what it gets
    }
    SerialExecutor serial;  // one thread: the resize faults as fast, nothing to do
    memory::Stats s2 = memory::stats();
    memory::prefault<float>(n, serial);
    memory::prefault<float>(1000, pool);  // a small block: operator new's, not ours
    memory::prefault<float>(SIZE_MAX / 2, pool);  // absurd: left to the allocation to refuse
    memory::configure({.cache_bytes = std::size_t{8} << 20, .huge_pages = true});  // no room for 12 MiB
    memory::prefault<float>(n, pool);
    CHECK(memory::stats().maps == s2.maps);
    CHECK(memory::stats().reuses == s2.reuses);
    memory::configure(keep);
}
