#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/wide.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/core/memory.hpp>
#include <sys/mman.h>
#include <unistd.h>

#include "generators.hpp"

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

/// The VmFlags of the mapping that holds p (/proc/self/smaps: "hg" advised MADV_HUGEPAGE, "nh"
/// MADV_NOHUGEPAGE), with a space at both ends; empty when not found.
std::string vm_flags(const void* p) {
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        std::uintptr_t lo = 0, hi = 0;
        char dash = 0;
        std::istringstream head(line);
        if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
            inside = lo <= address(p) && address(p) < hi;
            continue;
        }
        if (inside && line.rfind("VmFlags:", 0) == 0) return line.substr(8) + " ";
    }
    return {};
}
}  // namespace

TEST_CASE("in a SmallPagesWhereCheap scope a new large block keeps 4 KiB pages where their faults are cheap", "[memory]") {
    memory::Config keep = memory::config();
    const std::size_t bytes = std::size_t{16} << 20;  // 8 huge pages
    memory::Stats s0 = memory::stats();
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 1e9});  // every probe cheap
    {
        memory::LargeBuffer<unsigned char> hot(bytes);  // outside a scope: huge pages, no probe
        CHECK(memory::stats().small_page_blocks == s0.small_page_blocks);
        CHECK(vm_flags(hot.data() + bytes / 2).find(" hg ") != std::string::npos);
    }
    memory::SmallPagesWhereCheap scope;
    {
        memory::LargeBuffer<unsigned char> b(bytes);  // no cache: a fresh mapping
        CHECK(memory::stats().small_page_blocks == s0.small_page_blocks + 1);
        auto [resident, pages] = resident_pages(b.data(), std::size_t{1} << 20);
        CHECK(resident == pages);  // the probe faulted the first MiB in
        CHECK(vm_flags(b.data() + bytes / 2).find(" nh ") != std::string::npos);
        CHECK(vm_flags(b.data() + bytes / 2).find(" hg ") == std::string::npos);
        std::fill(b.data(), b.data() + bytes, std::uint8_t{1});
        CHECK(b.data()[bytes - 1] == 1);
    }
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 1e-9});  // every probe dear
    {
        memory::LargeBuffer<unsigned char> b(bytes);
        CHECK(memory::stats().small_page_blocks == s0.small_page_blocks + 1);
        CHECK(vm_flags(b.data() + bytes / 2).find(" hg ") != std::string::npos);
        CHECK(b.data()[0] == 0);  // the probe's writes leave fresh memory zero
    }
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 1e9});
    {
        memory::LargeBuffer<unsigned char> small(std::size_t{6} << 20);  // 3 huge pages: no probe
        CHECK(memory::stats().small_page_blocks == s0.small_page_blocks + 1);
        CHECK(vm_flags(small.data()).find(" hg ") != std::string::npos);
    }
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 0.0});  // never probe
    {
        memory::LargeBuffer<unsigned char> b(bytes);
        CHECK(memory::stats().small_page_blocks == s0.small_page_blocks + 1);
        CHECK(vm_flags(b.data() + bytes / 2).find(" hg ") != std::string::npos);
    }
    memory::configure(keep);
}

TEST_CASE("a cached block kept in 4 KiB pages is reused only inside a scope", "[memory]") {
    memory::Config keep = memory::config();
    const std::size_t bytes = std::size_t{16} << 20;
    memory::release_cache();
    memory::configure({.cache_bytes = std::size_t{256} << 20, .huge_pages = true, .small_page_limit_ms = 1e9});
    const void* small_block = nullptr;
    {
        memory::SmallPagesWhereCheap scope;
        memory::LargeBuffer<unsigned char> b(bytes);
        small_block = b.data();
        REQUIRE(vm_flags(b.data() + bytes / 2).find(" nh ") != std::string::npos);
    }
    const void* huge_block = nullptr;
    {
        memory::LargeBuffer<unsigned char> b(bytes);  // outside: not the cached small block
        huge_block = b.data();
        CHECK(b.data() != small_block);
        CHECK(vm_flags(b.data() + bytes / 2).find(" hg ") != std::string::npos);
    }
    {
        memory::SmallPagesWhereCheap scope;
        memory::LargeBuffer<unsigned char> b(bytes);  // inside: the small block first
        CHECK(b.data() == small_block);
        memory::LargeBuffer<unsigned char> c(bytes);  // then a huge-page block (warm) rather than a new map
        CHECK(c.data() == huge_block);
    }
    {
        memory::LargeBuffer<unsigned char> b(bytes);  // outside again: the huge-page block
        CHECK(b.data() == huge_block);
    }
    memory::release_cache();
    memory::configure(keep);
}

TEST_CASE("a WideTree's collapse scratch takes the page choice, its query arrays stay advised", "[memory]") {
    // 600,000 spheres: the collapse's sorted copy of them (9.6 MB) and its per-node facts are
    // scratch blocks of >= 8 MiB; the wide nodes are what queries walk.
    auto spheres = testing::random_spheres(600000, 17);
    std::span<const Sphere> ss(spheres);
    ThreadPool pool(2);
    bih::Tree tree = bih::build(ss, bih::Config{}, pool);
    memory::Config keep = memory::config();
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 1e9});  // every probe cheap
    memory::Stats s0 = memory::stats();
    {
        bih::WideTree<Sphere> wide(tree, ss, bih::WideConfig{}, pool);
        CHECK(memory::stats().small_page_blocks >= s0.small_page_blocks + 2);
        std::span<const bih::WideNode> nodes = wide.nodes();
        REQUIRE(nodes.size_bytes() >= (std::size_t{8} << 20));
        CHECK(vm_flags(nodes.data() + nodes.size() / 2).find(" hg ") != std::string::npos);
    }
    memory::configure(keep);
}

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
