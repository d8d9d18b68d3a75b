#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
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
    // 600,000 spheres, a wide leaf each (WideConfig{1}): the collapse's sorted copy of them
    // (9.6 MB), its per-node facts and costs are scratch blocks of >= 8 MiB; the wide nodes
    // (about 30 MB; 4.8 MB with the default leaf size of 8, since the collapse by least area)
    // are what queries walk.
    auto spheres = testing::random_spheres(600000, 17);
    std::span<const Sphere> ss(spheres);
    ThreadPool pool(2);
    bih::Tree tree = bih::build(ss, bih::Config{}, pool);
    memory::Config keep = memory::config();
    memory::configure({.cache_bytes = 0, .huge_pages = true, .small_page_limit_ms = 1e9});  // every probe cheap
    memory::Stats s0 = memory::stats();
    {
        bih::WideTree<Sphere> wide(tree, ss, bih::WideConfig{1}, pool);
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

TEST_CASE("blocks of 16 KiB up to 2 MiB are carved from 2 MiB chunks, cached on free and reused warm", "[memory]") {
    memory::Config keep = memory::config();
    // limit 0: a chunk's huge page is taken whatever it costs, so the pool stays on wherever
    // the kernel gives huge pages at all (THP "madvise" or "always").
    memory::configure({.cache_bytes = std::size_t{64} << 20, .huge_pages = true, .small_page_limit_ms = 0.0});
    memory::release_cache();
    memory::Stats s0 = memory::stats();
    const void* first = nullptr;
    {
        LargeVector<std::uint8_t> a(200000, 3);  // 200 KB: a block of 208 KiB (13 x 16 KiB)
        first = a.data();
        memory::release_cache();  // the rest of a chunk a's carve moved on from, if it did
        CHECK(address(a.data()) % memory::kCachedBlock == 0);
        CHECK(a[199999] == 3u);
    }
    memory::Stats s1 = memory::stats();
    CHECK(s1.maps == s0.maps + 1);
    CHECK(s1.cached_bytes == std::size_t{208} << 10);
    {
        LargeVector<std::uint8_t> b(150000);  // fits the cached block (at most twice its size)
        CHECK(b.data() == first);
        CHECK(b[149999] == 0u);
        LargeVector<std::uint8_t> c(10000);  // under 16 KiB: operator new's
        CHECK(c.data() != first);
        memory::Stats s2 = memory::stats();
        CHECK(s2.reuses == s1.reuses + 1);
        CHECK(s2.maps == s1.maps);
        CHECK(s2.cached_bytes == 0);
    }
    {
        // Fresh blocks, beyond what one chunk holds: none overlaps another, each keeps its bytes.
        std::vector<LargeVector<std::uint32_t>> blocks;
        const std::size_t chunks = memory::stats().pool_chunks;
        for (std::uint32_t k = 0; k < 12; ++k) blocks.emplace_back(60000 + 1000 * k, k);  // 240-284 KB each
        for (std::size_t i = 0; i < blocks.size(); ++i) {
            const auto lo = address(blocks[i].data()), hi = lo + blocks[i].size() * sizeof(std::uint32_t);
            for (std::size_t j = 0; j < blocks.size(); ++j) {
                if (j == i) continue;
                const auto lo2 = address(blocks[j].data()), hi2 = lo2 + blocks[j].size() * sizeof(std::uint32_t);
                CHECK((hi <= lo2 || hi2 <= lo));
            }
            CHECK(std::all_of(blocks[i].begin(), blocks[i].end(), [&](std::uint32_t v) { return v == i; }));
        }
        memory::Stats s3 = memory::stats();
        if (!s3.pool_off) {  // the kernel gave the chunks huge pages: ~3 MB took two or more
            CHECK(s3.pool_chunks >= chunks + 1);
            CHECK(vm_flags(blocks.back().data()).find(" hg ") != std::string::npos);
            const auto chunk = address(blocks.back().data()) / memory::kPoolChunk;
            CHECK(address(blocks.back().data() + blocks.back().size() - 1) / memory::kPoolChunk == chunk);
        } else {
            WARN("no huge pages here (THP off?): small blocks were mapped one by one");
        }
        // A block between 1 and 2 MiB is carved too (kLargeBlock is one huge page), not mapped
        // on its own: it starts inside the current chunk (not 2 MiB-aligned) or starts a new
        // one, and lies in one chunk. (Mapped on its own, as before 2026-12-07, it would be
        // 2 MiB-aligned with no new chunk; the cache holds no block of 1.1-2.2 MB here.)
        const memory::Stats s5 = memory::stats();
        LargeVector<std::uint8_t> mid(1100000, 9);  // 1.1 MB: 68 x 16 KiB
        CHECK(address(mid.data()) % memory::kCachedBlock == 0);
        CHECK(mid[1099999] == 9u);
        if (!memory::stats().pool_off) {
            const std::size_t new_chunks = memory::stats().pool_chunks - s5.pool_chunks;
            CHECK(new_chunks <= 1);
            CHECK((address(mid.data()) % memory::kHugePage != 0 || new_chunks == 1));
            CHECK(address(mid.data()) / memory::kPoolChunk == address(mid.data() + mid.size() - 1) / memory::kPoolChunk);
        }
    }
    {
        // Huge pages off: a new small block is a mapping of its own, not carved, not advised.
        memory::configure({.cache_bytes = 0, .huge_pages = false});
        const memory::Stats s4 = memory::stats();
        LargeVector<std::uint8_t> d(100000, 5);
        CHECK(memory::stats().maps == s4.maps + 1);
        CHECK(memory::stats().pool_chunks == s4.pool_chunks);
        CHECK(vm_flags(d.data()).find(" hg ") == std::string::npos);
        CHECK(d[99999] == 5u);
    }
    memory::configure({.cache_bytes = 0, .huge_pages = true});  // gives them back
    CHECK(memory::stats().cached_bytes == 0);
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

TEST_CASE("a RunArena's runs grow in place, move when their slab is full and give back what they did not use",
          "[memory]") {
    memory::Config keep = memory::config();
    memory::configure({.cache_bytes = std::size_t{64} << 20, .huge_pages = true});
    memory::release_cache();
    const std::size_t block = (std::size_t{1} << 20) / sizeof(std::uint64_t);  // one MiB of elements
    memory::Stats s0 = memory::stats();
    {
        memory::RunArena<std::uint64_t> arena(block);
        auto a = arena.open(100);
        for (std::uint64_t k = 0; k < 10; ++k) a.emplace_back() = k;
        CHECK(a.open());
        arena.close(a);
        CHECK_FALSE(a.open());
        arena.close(a);  // a second close does nothing
        auto b = arena.open(100);  // the same slab, right after a's ten elements
        b.emplace_back() = 99;
        CHECK(&b[0] == &a[0] + 10);
        CHECK(b.emplace_back() == 0u);  // value-initialised
        // b outgrows the slab: it moves to a new block, values kept, a untouched.
        for (std::uint64_t k = 2; k < block + 5; ++k) b.emplace_back() = 1000 + k;
        REQUIRE(b.size() == block + 5);
        CHECK(b[0] == 99u);
        CHECK(b[1] == 0u);
        bool same = true;
        for (std::uint64_t k = 2; k < block + 5; ++k) same = same && b[k] == 1000 + k;
        CHECK(same);
        for (std::uint64_t k = 0; k < 10; ++k) CHECK(a[k] == k);
        arena.close(b);
        CHECK(arena.blocks() == 2);
        CHECK_THROWS_AS(b.emplace_back(), std::logic_error);  // closed: no more appends
        memory::RunArena<std::uint64_t>::Run never;
        CHECK_THROWS_AS(never.emplace_back(), std::logic_error);
        // The room b left in the first block, or the rest of b's new one, serves the next run
        // without a new block.
        auto c = arena.open(1000);
        c.emplace_back() = 7;
        CHECK((&c[0] == &a[0] + 10 || &c[0] == &b[0] + b.size()));
        arena.close(c);
        CHECK(arena.blocks() == 2);
        static_assert(!std::is_copy_constructible_v<memory::RunArena<std::uint64_t>::Run>);
        auto d = arena.open(10);
        d.emplace_back() = 5;
        auto e = std::move(d);  // the run moves; the source is empty and closed
        CHECK(e.size() == 1);
        CHECK(e[0] == 5u);
        CHECK(d.size() == 0);
        CHECK_FALSE(d.open());
        CHECK_THROWS_AS(d.emplace_back(), std::logic_error);
        arena.close(e);
        CHECK(memory::stats().maps >= s0.maps + 1);
    }
    // The blocks went back to the cache, warm for the next build.
    CHECK(memory::stats().cached_bytes >= s0.cached_bytes + (std::size_t{2} << 20));
    memory::configure(keep);
}

TEST_CASE("a RunArena serves runs on several threads at once, each intact", "[memory][parallel]") {
    ThreadPool pool(4);
    memory::RunArena<std::uint32_t> arena(std::size_t{1} << 18);
    constexpr std::size_t kRuns = 64;
    std::vector<memory::RunArena<std::uint32_t>::Run> runs(kRuns);
    pool.parallel_for(0, kRuns, 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t r = lo; r < hi; ++r) {
            runs[r] = arena.open(r % 3 == 0 ? 16 : 4096);  // some grow, some stay in their room
            const std::size_t n = 1000 + 997 * r;
            for (std::size_t k = 0; k < n; ++k) runs[r].emplace_back() = static_cast<std::uint32_t>(r * 100000 + k);
            arena.close(runs[r]);
        }
    });
    std::size_t wrong = 0;
    std::vector<std::pair<const std::uint32_t*, const std::uint32_t*>> spans;
    for (std::size_t r = 0; r < kRuns; ++r) {
        const std::size_t n = 1000 + 997 * r;
        REQUIRE(runs[r].size() == n);
        for (std::size_t k = 0; k < n; ++k) wrong += runs[r][k] != r * 100000 + k;
        spans.push_back({&runs[r][0], &runs[r][0] + n});
    }
    CHECK(wrong == 0);
    std::sort(spans.begin(), spans.end());
    for (std::size_t i = 1; i < spans.size(); ++i) CHECK(spans[i - 1].second <= spans[i].first);  // no overlap
}

TEST_CASE("a parallel BIH build keeps its chunks in an arena and gives the same tree as a serial one", "[memory][parallel]") {
    auto spheres = testing::random_spheres(20000, 11);
    std::span<const Sphere> ss(spheres);
    SerialExecutor serial;
    ThreadPool pool(2);
    bih::Tree one = bih::build(ss, bih::Config{}, serial);
    memory::Stats s0 = memory::stats();
    bih::Tree two = bih::build(ss, bih::Config{}, pool);
    memory::Stats s1 = memory::stats();
    CHECK(s1.maps + s1.reuses > s0.maps + s0.reuses + 2);  // arena blocks besides records and nodes
    REQUIRE(one.nodes.size() == two.nodes.size());
    CHECK(std::equal(one.nodes.begin(), one.nodes.end(), two.nodes.begin(), [](const bih::Node& a, const bih::Node& b) {
        return std::memcmp(&a, &b, sizeof(bih::Node)) == 0;
    }));
    CHECK(std::equal(one.order.begin(), one.order.end(), two.order.begin()));
}

TEST_CASE("a RunOrVector appends and indexes alike as a LargeVector and as an arena run", "[memory]") {
    memory::RunArena<std::uint32_t> arena(std::size_t{1} << 12);
    memory::RunOrVector<std::uint32_t> in_vector, in_arena;
    in_vector.start(nullptr, 8);
    in_arena.start(&arena, 8);
    CHECK_FALSE(in_vector.in_arena());
    CHECK(in_arena.in_arena());
    for (std::uint32_t k = 0; k < 10000; ++k) {  // both grow past their first room
        in_vector.push_back(3 * k);
        in_arena.emplace_back() = 3 * k;
    }
    in_arena[5] = 1;
    in_vector[5] = 1;
    in_vector.close();
    in_arena.close();
    REQUIRE(in_vector.size() == 10000);
    REQUIRE(in_arena.size() == 10000);
    bool same = true;
    for (std::uint32_t k = 0; k < 10000; ++k)
        same = same && in_vector[k] == in_arena[k] && in_arena[k] == (k == 5 ? 1 : 3 * k);
    CHECK(same);
    CHECK(in_vector.vector().size() == 10000);  // the vector is the array itself
    CHECK(in_arena.vector().empty());
    CHECK(arena.blocks() >= 2);  // 10,000 elements outgrew the 4,096 of the first block
}
