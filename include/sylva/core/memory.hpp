// sylva/core/memory.hpp -- the allocator of the large arrays of builders, encoders and renderers.
//
// Why: on a machine whose memory has not been touched yet, the first write to each 4 KiB page
// costs a page fault and a zeroed page (measured on the project's 2-core machines: 200 ms to
// 1.3 s per 400 MB, against 16-22 ms to rewrite the same memory). A builder that allocates its
// nodes afresh on every build pays that on every build; Embree does not (it allocates in large
// blocks, with transparent huge pages, and keeps them). Two remedies, both here:
//   1. Huge pages: blocks of at least kLargeBlock bytes are mapped 2 MiB-aligned and
//      advised MADV_HUGEPAGE (Debian's default THP mode is "madvise", so without the advice
//      the kernel uses 4 KiB pages): one fault per 2 MiB. Measured on the same machine, 400 MB:
//      first touch 205 ms with 4 KiB pages, 54 ms with huge pages (the very first huge-page
//      mapping of a process can cost more while the kernel compacts memory). On a machine that
//      has run for hours it depends on where the pages come from: these machines are
//      Firecracker guests with free page reporting (virtio_balloon, page_reporting_order=11):
//      free blocks of 8 MiB and more are handed back to the host, and the next use of such
//      memory faults on the host again. Huge pages are carved from those blocks, 4 KiB pages
//      mostly from recycled small ones; measured on one such machine (README, "Cold and steady
//      state"), 400 MB took 130-230 ms with 4 KiB pages and either 25-40 ms or 490-710 ms
//      advised. So a builder's scratch and intermediate arrays (mapped inside a
//      SmallPagesWhereCheap scope) first time the faults of their first MiB in 4 KiB pages
//      (MADV_NOHUGEPAGE): where they are cheap (Config::small_page_limit_ms) the block keeps
//      4 KiB pages, else the rest is advised MADV_HUGEPAGE. Measured on such a machine,
//      128 MB after 3 s idle: 1.2-1.8 s advised (5-35 ms a huge page), 47-58 ms in 4 KiB pages
//      (0.35-0.45 ms a MiB); back to back the huge pages took 17 ms once. On a new machine 4 KiB
//      faults cost about 3 ms a MiB and huge pages 0.1 ms. Arrays that queries traverse (a
//      WideTree, an encoding) keep huge pages: in 4 KiB pages WideTree queries at 10^7 spheres
//      ran 13-15 % slower (TLB reach). What holds on every machine is touching less and
//      touching it once:
//   2. Keeping capacity: freed large blocks go to a process-wide cache (bounded by
//      Config::cache_bytes) and the next large allocation of a similar size reuses one, whose
//      pages are already faulted in. So rebuilding a tree of the same size every frame touches
//      warm memory, as a builder object that keeps its vectors would, but for every builder.
// Blocks of kCachedBlock (16 KiB) up to kLargeBlock are carved from 2 MiB chunks in huge pages
// (where those come cheaply, else mapped one by one in 4 KiB pages) and cached the same way;
// smaller ones use the ordinary aligned operator new.
//
// LargeVector<T> is a std::vector with this allocator; the BIH's nodes, element order and the
// builder's scratch use it. RunArena<T> carves many growing arrays from its blocks (a parallel
// BIH build's subtree chunks).
#ifndef SYLVA_CORE_MEMORY_HPP
#define SYLVA_CORE_MEMORY_HPP

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <new>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "sylva/core/executor.hpp"

#if defined(__unix__)
#include <unistd.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#include <sys/resource.h>
#define SYLVA_MEMORY_MMAP 1
#else
#define SYLVA_MEMORY_MMAP 0
#endif

namespace sylva::memory {

/// The huge page size on x86-64 and most AArch64 Linux kernels.
inline constexpr std::size_t kHugePage = std::size_t{2} << 20;

/// Blocks of at least this many bytes are mapped 2 MiB-aligned (huge pages where advised) and
/// cached on free. 2 MiB, one huge page: a smaller block shares a chunk's huge page with others
/// (kPoolChunk) instead of taking one of its own. It was 1 MiB until 2026-12-07, when a block of
/// 1.06 MB (the node array of a default BIH over 10^4 spheres) took a whole huge page beside the
/// chunk that held the build's other arrays, two fresh huge pages in a first build instead of
/// one (sylva-bench's cold children of that build, 8 processes of each binary alternated:
/// median 2.67 -> 2.34 ms uniform and 2.67 -> 2.36 clustered, Embree's 3.02 and 2.58, on a VM
/// where a fresh huge page cost 0.34-6.9 ms; 10^5 and 10^6 and steady builds the same within
/// the spread; README, "Known gaps"). A constant, so a block is freed the way it was allocated
/// whatever the settings do meanwhile.
inline constexpr std::size_t kLargeBlock = std::size_t{2} << 20;

/// The block size the builders' arenas (RunArena: the BIH's chunk runs, the WideTree
/// collapse's parts) start from or stop at: 1 MiB, two blocks a chunk where they are carved.
/// It was kLargeBlock until that grew to 2 MiB; kept apart so the arenas' blocks did not move.
inline constexpr std::size_t kArenaBlock = std::size_t{1} << 20;

/// Blocks from this many bytes up to kLargeBlock (in multiples of this) come from this allocator
/// and are cached on free as well; smaller ones use operator new. Why: a build over 10^4-10^5
/// elements has arrays of 16 KiB-1 MiB (the BIH's scratch and order, the WideTree's facts,
/// nodes, leaf records and ids), and glibc takes them from a heap whose top it gives back, or
/// maps each above 128 KiB afresh and unmaps it when freed: 4 KiB pages faulted anew in every
/// build. From the cache a collapse reuses what the build just freed. New blocks are carved
/// from 2 MiB chunks advised huge pages (kPoolChunk), since what a first build pays for is the
/// first use of each page: on this project's VMs ~4-15 us a 4 KiB page even after the kernel
/// has populated it (no fault is counted; it looks like the hypervisor's cost, paid at the
/// first access from user space: a fresh process wrote 320 KB in 0.27-0.53 ms after
/// MAP_POPULATE, 0.004 ms the second time), against 0.08-0.24 ms for a whole huge page (30
/// fresh processes, median 0.14 ms, one of 3.9 ms; 1.4 MB of 4 KiB pages 3.1-7.3 ms, median 3.4). A first WideTree build over 10^4 spheres touches
/// about 1.4 MB of such arrays. Where huge pages do not come (THP off) or cost more than 2 MiB
/// of 4 KiB faults would at Config::small_page_limit_ms, and with Config::huge_pages off, each
/// block is mapped on its own, populated (MAP_POPULATE: one call instead of a fault a page).
/// A constant, like kLargeBlock.
inline constexpr std::size_t kCachedBlock = std::size_t{16} << 10;
/// The chunks small blocks (kCachedBlock up to kLargeBlock) are carved from: one huge page.
inline constexpr std::size_t kPoolChunk = kHugePage;
#if defined(MAP_POPULATE)
inline constexpr int kPopulate = MAP_POPULATE;
#else
inline constexpr int kPopulate = 0;
#endif

/// The default Config::cache_bytes: 4 GiB, at most a quarter of the physical memory.
inline std::size_t default_cache_bytes() {
    std::size_t cap = std::size_t{4} << 30;
#if defined(__unix__)
    long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) cap = std::min(cap, static_cast<std::size_t>(pages) / 4 * static_cast<std::size_t>(page));
#endif
    return std::max(cap, std::size_t{256} << 20);
}

/// Settings of the large-block allocator (process-wide).
struct Config {
    /// Bytes of freed large blocks kept for reuse (0 = return every block to the system); the
    /// cache gives memory back beyond it. Default: 4 GiB, or a quarter of the physical memory
    /// where that is less (default_cache_bytes()). A rebuild of the default BIH over 10^7
    /// spheres frees and reallocates 1.7 GB (1.37 GB of nodes, the scratch): with the former
    /// 1 GiB every such rebuild mapped fresh memory (steady builds 1.35-2.9 s instead of 1.5 s).
    std::size_t cache_bytes = default_cache_bytes();
    /// Advise MADV_HUGEPAGE on large blocks (inside a SmallPagesWhereCheap scope only where 4 KiB
    /// faults are dear, below), and carve small blocks from huge-page chunks (kCachedBlock);
    /// false: 4 KiB pages for all, small blocks mapped one by one.
    bool huge_pages = true;
    /// Inside a SmallPagesWhereCheap scope, a new block of at least 4 huge pages first touches
    /// its first MiB in 4 KiB pages; when that took less than this many ms, 4 KiB faults are
    /// cheap on this machine and the block keeps 4 KiB pages (no huge-page lottery), otherwise
    /// the rest of it is advised MADV_HUGEPAGE. 1.5: 4 KiB faults cost 0.35-0.45 ms a MiB on a
    /// VM that has run for hours (where a huge page can cost 5-35 ms), about 3 ms on a new one
    /// (where it costs 0.1 ms). 0: always advise.
    double small_page_limit_ms = 1.5;
};

/// Counters of the large-block allocator.
struct Stats {
    std::size_t mapped_bytes = 0;   ///< bytes currently mapped (in use + cached)
    std::size_t cached_bytes = 0;   ///< bytes in the cache
    std::size_t maps = 0;           ///< blocks mapped from the system so far
    std::size_t reuses = 0;         ///< allocations served from the cache so far
    std::size_t small_page_blocks = 0;  ///< blocks kept in 4 KiB pages (their faults were cheap)
    std::size_t pool_chunks = 0;        ///< 2 MiB chunks mapped for small blocks (kPoolChunk)
    /// Small blocks are mapped one by one in 4 KiB pages: huge pages are off, or a chunk's huge
    /// page did not come or came dear (kCachedBlock). Until the next configure().
    bool pool_off = false;
};

namespace detail {
/// How many SmallPagesWhereCheap scopes are open on this thread.
inline int& small_pages_scopes() {
    thread_local int open = 0;
    return open;
}

class LargeBlocks {
public:
    /// Never destroyed: a LargeVector in a static object may be freed after any destructor
    /// of this header's statics would have run. Its blocks are reachable until exit.
    static LargeBlocks& instance() {
        static LargeBlocks* blocks = new LargeBlocks;
        return *blocks;
    }

    Config config() {
        std::lock_guard lock(mutex_);
        return config_;
    }
    void set_config(const Config& c) {
        std::lock_guard lock(mutex_);
        config_ = c;
        stats_.pool_off = false;  // the new settings get a chunk of their own to decide by
        trim_locked(config_.cache_bytes);
    }
    Stats stats() {
        std::lock_guard lock(mutex_);
        return stats_;
    }
    void release_cache() {
        std::lock_guard lock(mutex_);
        trim_locked(0);
    }

    /// A block of at least `bytes`: from kLargeBlock on a multiple of kHugePage, 2 MiB-aligned
    /// where mapped; below it a multiple of kCachedBlock, carved from a chunk (kPoolChunk) or
    /// mapped in 4 KiB pages.
    void* allocate(std::size_t bytes) {
        const std::size_t size = bytes < kLargeBlock ? round_up_small(bytes) : round_up(bytes);
        const bool scoped = small_pages_scopes() > 0;
        {
            std::lock_guard lock(mutex_);
            auto it = reusable_locked(size, scoped);
            if (it != cache_.end()) {
                Block b = it->second;
                std::size_t got = it->first;
                cache_.erase(it);
                stats_.cached_bytes -= got;
                ++stats_.reuses;
                live_[b.p] = {got, b.small};
                return b.p;
            }
            if (size < kLargeBlock) {
                if (void* carved = carve_locked(size)) {
                    live_[carved] = {size, false};
                    stats_.mapped_bytes += size;
                    ++stats_.maps;
                    return carved;
                }
            }
        }
        Block b = map(size);
        std::lock_guard lock(mutex_);
        live_[b.p] = {size, b.small};
        stats_.mapped_bytes += size;
        ++stats_.maps;
        return b.p;
    }

    void deallocate(void* p) {
        std::lock_guard lock(mutex_);
        auto it = live_.find(p);
        if (it == live_.end()) return;  // not ours: cannot happen through LargeAllocator
        Live l = it->second;
        live_.erase(it);
        cache_.emplace(l.size, Block{p, l.small});
        stats_.cached_bytes += l.size;
        trim_locked(config_.cache_bytes);
    }

    LargeBlocks(const LargeBlocks&) = delete;
    LargeBlocks& operator=(const LargeBlocks&) = delete;

private:
    /// A mapped block and whether it was left in 4 KiB pages (inside a SmallPagesWhereCheap scope).
    struct Block {
        void* p;
        bool small;
    };
    struct Live {
        std::size_t size;
        bool small;
    };

    LargeBlocks() = default;

    /// The cached block a new allocation of `size` bytes takes, cache_.end() for none: the best
    /// fit no more than twice the size (no large waste). Outside a SmallPagesWhereCheap scope
    /// only blocks in huge pages qualify (the arrays queries walk: a block kept in 4 KiB pages
    /// would cost them TLB reach for as long as it lives); inside one, blocks in 4 KiB pages
    /// come first and huge-page blocks after them.
    /// A block under kLargeBlock takes the best fit whatever its pages (no TLB reach to keep).
    std::multimap<std::size_t, Block>::iterator reusable_locked(std::size_t size, bool scoped) {
        if (size < kLargeBlock) {
            auto it = cache_.lower_bound(size);
            return it != cache_.end() && it->first <= 2 * size ? it : cache_.end();
        }
        auto huge = cache_.end();
        for (auto it = cache_.lower_bound(size); it != cache_.end() && it->first <= 2 * size; ++it) {
            if (it->second.small) {
                if (scoped) return it;
            } else if (huge == cache_.end()) {
                if (!scoped) return it;
                huge = it;
            }
        }
        return huge;
    }

    static std::size_t round_up(std::size_t bytes) {
        if (bytes > SIZE_MAX - kHugePage) throw std::bad_alloc();
        return (std::max<std::size_t>(bytes, 1) + kHugePage - 1) / kHugePage * kHugePage;
    }

    static std::size_t round_up_small(std::size_t bytes) {
        return (std::max<std::size_t>(bytes, 1) + kCachedBlock - 1) / kCachedBlock * kCachedBlock;
    }

    /// A new small block of `size` bytes (a multiple of kCachedBlock, under kLargeBlock) from
    /// the current chunk, or from a new one when it has no room (what is left of the old one
    /// goes to the cache as a free block); nullptr when small blocks are mapped one by one
    /// (huge pages off; Stats::pool_off once the current chunk is used up).
    void* carve_locked(std::size_t size) {
#if SYLVA_MEMORY_MMAP
        if (!config_.huge_pages) return nullptr;
        if (static_cast<std::size_t>(pool_end_ - pool_top_) < size) {
            if (stats_.pool_off) return nullptr;
            unsigned char* chunk = new_chunk_locked();
            if (!chunk) return nullptr;
            if (const auto rest = static_cast<std::size_t>(pool_end_ - pool_top_); rest >= kCachedBlock) {
                try {
                    cache_.emplace(rest, Block{pool_top_, false});
                    stats_.cached_bytes += rest;
                    stats_.mapped_bytes += rest;
                } catch (...) {  // no room in the list: the rest stays unused, nothing else lost
                }
            }
            pool_top_ = chunk;
            pool_end_ = chunk + kPoolChunk;
        }
        void* p = pool_top_;
        pool_top_ += size;
        return p;
#else
        (void)size;
        return nullptr;
#endif
    }

#if SYLVA_MEMORY_MMAP
    /// Maps `size` bytes (a multiple of kHugePage) aligned to kHugePage: maps size + 2 MiB and
    /// unmaps the slop. No advice. nullptr where the mapping fails.
    static void* map_huge_aligned(std::size_t size) {
        void* raw = ::mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) return nullptr;
        const auto base = reinterpret_cast<std::uintptr_t>(raw);
        const std::uintptr_t aligned = (base + kHugePage - 1) / kHugePage * kHugePage;
        if (aligned > base) ::munmap(raw, aligned - base);
        if (const std::size_t tail = base + kHugePage - aligned; tail > 0)
            ::munmap(reinterpret_cast<void*>(aligned + size), tail);
        return reinterpret_cast<void*>(aligned);
    }

    /// Faults of the calling thread so far (minor and major).
    static long thread_faults() {
#if defined(RUSAGE_THREAD)
        rusage u{};
        if (::getrusage(RUSAGE_THREAD, &u) != 0) return -1;
        return u.ru_minflt + u.ru_majflt;
#else
        return -1;
#endif
    }

    /// Maps a chunk of kPoolChunk bytes, 2 MiB-aligned and advised MADV_HUGEPAGE, and touches
    /// its first and last byte, which is one fault where the kernel gave it a huge page. Where
    /// it did not (two faults, or no fault count), or the first fault took longer than 2 MiB of
    /// 4 KiB faults would at Config::small_page_limit_ms (the kernel compacting memory to find
    /// one), later small blocks are mapped one by one (Stats::pool_off); this chunk is carved all
    /// the same. nullptr where the mapping fails (small blocks then mapped one by one).
    unsigned char* new_chunk_locked() {
        static_assert(kPoolChunk == kHugePage);
        auto* chunk = static_cast<unsigned char*>(map_huge_aligned(kPoolChunk));
        if (!chunk) {
            stats_.pool_off = true;
            return nullptr;
        }
#if defined(MADV_HUGEPAGE)
        ::madvise(chunk, kPoolChunk, MADV_HUGEPAGE);
#endif
        (void)std::chrono::steady_clock::now();  // its first call may fault (vDSO data)
        const long before = thread_faults();
        const auto start = std::chrono::steady_clock::now();
        static_cast<volatile unsigned char*>(chunk)[0] = 0;
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        static_cast<volatile unsigned char*>(chunk)[kPoolChunk - 1] = 0;
        const long faults = thread_faults() - before;
        const double limit_ms = config_.small_page_limit_ms;
        if (before < 0 || faults != 1 || (limit_ms > 0.0 && ms > 2.0 * limit_ms)) stats_.pool_off = true;
        ++stats_.pool_chunks;
        return chunk;
    }
#endif

    /// Maps `size` bytes aligned to kHugePage (maps size + 2 MiB, unmaps the slop); under
    /// kLargeBlock, page-aligned in 4 KiB pages, no advice.
    Block map(std::size_t size) {
#if SYLVA_MEMORY_MMAP
        if (size < kLargeBlock) {  // populated: one call instead of a fault a page (see kCachedBlock)
            void* small = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | kPopulate, -1, 0);
            if (small == MAP_FAILED) throw std::bad_alloc();
            return {small, true};
        }
        void* p = map_huge_aligned(size);
        if (!p) throw std::bad_alloc();
        bool small = false;
        bool huge;
        double limit_ms;
        {
            std::lock_guard lock(mutex_);
            huge = config_.huge_pages;
            limit_ms = config_.small_page_limit_ms;
        }
#if defined(MADV_HUGEPAGE) && defined(MADV_NOHUGEPAGE)
        if (huge && limit_ms > 0.0 && size >= 4 * kHugePage && small_pages_scopes() > 0) {
            auto* bytes = static_cast<unsigned char*>(p);
            ::madvise(bytes, kHugePage, MADV_NOHUGEPAGE);
            bool cheap = small_faults_ms(bytes, std::size_t{1} << 20) < limit_ms;
            ::madvise(bytes + kHugePage, size - kHugePage, cheap ? MADV_NOHUGEPAGE : MADV_HUGEPAGE);
            if (cheap) {
                small = true;
                std::lock_guard lock(mutex_);
                ++stats_.small_page_blocks;
            }
        } else if (huge) {
            ::madvise(p, size, MADV_HUGEPAGE);
        }
#endif
        return {p, small};
#else
        return {::operator new(size, std::align_val_t{kHugePage}), false};
#endif
    }

    /// Milliseconds to fault in `bytes` of fresh 4 KiB pages at p (one write a page; zero stays
    /// zero).
    static double small_faults_ms(unsigned char* p, std::size_t bytes) {
        auto start = std::chrono::steady_clock::now();
        for (std::size_t at = 0; at < bytes; at += 4096) static_cast<volatile unsigned char*>(p)[at] = 0;
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    }

    void unmap(void* p, std::size_t size) {
#if SYLVA_MEMORY_MMAP
        ::munmap(p, size);
#else
        ::operator delete(p, std::align_val_t{kHugePage});
        (void)size;
#endif
    }

    /// Gives cached blocks back to the system, largest first, until at most `keep` bytes stay.
    void trim_locked(std::size_t keep) {
        while (stats_.cached_bytes > keep && !cache_.empty()) {
            auto it = std::prev(cache_.end());
            unmap(it->second.p, it->first);
            stats_.cached_bytes -= it->first;
            stats_.mapped_bytes -= it->first;
            cache_.erase(it);
        }
    }

    std::mutex mutex_;
    Config config_;
    Stats stats_;
    std::multimap<std::size_t, Block> cache_;  ///< free blocks by size
    std::unordered_map<void*, Live> live_;     ///< blocks in use, their sizes and pages
    unsigned char* pool_top_ = nullptr;        ///< the free rest of the current chunk: [top, end)
    unsigned char* pool_end_ = nullptr;
};

}  // namespace detail

/// While it lives, new large blocks mapped on this thread keep 4 KiB pages where their faults
/// are cheap (Config::small_page_limit_ms). For arrays written once and read little, a
/// builder's scratch and intermediate tree: there a huge page that the host must fault in again
/// costs more than the array's whole use. Blocks reused from the cache keep their pages, so a
/// block kept in 4 KiB pages is handed out again only inside a scope (LargeBlocks::allocate).
class SmallPagesWhereCheap {
public:
    SmallPagesWhereCheap() { ++detail::small_pages_scopes(); }
    ~SmallPagesWhereCheap() { --detail::small_pages_scopes(); }
    SmallPagesWhereCheap(const SmallPagesWhereCheap&) = delete;
    SmallPagesWhereCheap& operator=(const SmallPagesWhereCheap&) = delete;
};

/// The allocator's current settings.
inline Config config() { return detail::LargeBlocks::instance().config(); }
/// Changes the settings (a smaller cache gives memory back at once).
inline void configure(const Config& c) { detail::LargeBlocks::instance().set_config(c); }
/// Counters: mapped, cached, maps, reuses.
inline Stats stats() { return detail::LargeBlocks::instance().stats(); }
/// Gives every cached block back to the system (e.g. after the last build of a session).
inline void release_cache() { detail::LargeBlocks::instance().release_cache(); }

/// A std allocator: blocks from kCachedBlock bytes on from the cache / mappings above (huge
/// pages from kLargeBlock on), small ones from aligned operator new (64-byte alignment: whole
/// cache lines for SIMD node loads).
template <class T>
struct LargeAllocator {
    using value_type = T;
    static constexpr std::size_t kAlign = std::max<std::size_t>(alignof(T), 64);

    LargeAllocator() noexcept = default;
    template <class U>
    LargeAllocator(const LargeAllocator<U>&) noexcept {}

    T* allocate(std::size_t n) {
        if (n > SIZE_MAX / sizeof(T)) throw std::bad_alloc();
        std::size_t bytes = n * sizeof(T);
        if (bytes >= kCachedBlock)
            return static_cast<T*>(detail::LargeBlocks::instance().allocate(bytes));
        return static_cast<T*>(::operator new(bytes, std::align_val_t{kAlign}));
    }
    void deallocate(T* p, std::size_t n) noexcept {
        std::size_t bytes = n * sizeof(T);
        if (bytes >= kCachedBlock) detail::LargeBlocks::instance().deallocate(p);
        else ::operator delete(p, std::align_val_t{kAlign});
    }
    template <class U>
    bool operator==(const LargeAllocator<U>&) const noexcept {
        return true;
    }
};

/// Uninitialised storage for n trivially copyable T from LargeAllocator (scratch arrays that are
/// written before they are read: no zeroing pass, as std::make_unique_for_overwrite).
template <class T>
class LargeBuffer {
    static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);

public:
    explicit LargeBuffer(std::size_t n) : n_(n), p_(n ? LargeAllocator<T>().allocate(n) : nullptr) {}
    LargeBuffer(const LargeBuffer&) = delete;
    LargeBuffer& operator=(const LargeBuffer&) = delete;
    ~LargeBuffer() {
        if (p_) LargeAllocator<T>().deallocate(p_, n_);
    }
    [[nodiscard]] T* data() { return p_; }
    [[nodiscard]] const T* data() const { return p_; }
    [[nodiscard]] std::size_t size() const { return n_; }

private:
    std::size_t n_;
    T* p_;
};

/// Storage for many arrays of trivially copyable T that grow at once on several threads and are
/// read once before they all go together: the node chunks of a parallel tree build. Why not a
/// LargeVector each: most chunks are smaller than kLargeBlock, so they came from operator new,
/// where glibc maps every one above 128 KiB afresh in 4 KiB pages and unmaps it when freed. On
/// the project's VMs a 4 KiB fault costs about 10 us whether or not the memory was used before
/// (400 MB: 1.0-1.2 s, rep after rep), against 0.06 ms a MiB to rewrite huge pages the process
/// has freed, so a default BIH build over 10^6 spheres took 33-36 k faults and 520-640 ms the
/// first two times in a process, 180 ms once glibc had raised its mapping threshold; at 10^7,
/// 366 k faults and 4.6 s. Here the arrays are runs carved from large blocks of LargeAllocator
/// (huge pages where they help, kept in its cache when the arena goes, so the next build
/// reuses warm memory): each open run has a slab (the rest of a block) to itself, grows in
/// place at its top and, when closed, gives back what it did not use. A run outgrowing its
/// slab moves to a new one (copied). Closed runs stay readable until the arena goes.
/// Thread safety: open() and close() of different runs may run concurrently; one run is used
/// by one thread at a time.
template <class T>
class RunArena {
    static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);

    /// The free part of a block: [top, end).
    struct Slab {
        T* top = nullptr;
        T* end = nullptr;
    };

public:
    /// An array being appended to (open) or finished (closed); see RunArena.
    class Run {
    public:
        Run() = default;
        /// Move-only: two copies of an open run would append to the same slab. A moved-from run
        /// is empty and closed.
        Run(Run&& o) noexcept { *this = std::move(o); }
        Run& operator=(Run&& o) noexcept {
            if (this != &o) {
                arena_ = o.arena_;
                data_ = o.data_;
                end_ = o.end_;
                size_ = o.size_;
                o.reset();
            }
            return *this;
        }
        Run(const Run&) = delete;
        Run& operator=(const Run&) = delete;
        /// Appends a value-initialised T and returns it (references stay valid until the next
        /// append that needs more room than the slab has).
        T& emplace_back() {
            if (data_ + size_ == end_) grow();
            return *::new (static_cast<void*>(data_ + size_++)) T();
        }
        T& operator[](std::size_t i) { return data_[i]; }
        const T& operator[](std::size_t i) const { return data_[i]; }
        [[nodiscard]] std::size_t size() const { return size_; }
        [[nodiscard]] bool open() const { return arena_ != nullptr; }

    private:
        friend class RunArena;
        void reset() {
            arena_ = nullptr;
            data_ = end_ = nullptr;
            size_ = 0;
        }
        void grow() {
            if (!arena_) throw std::logic_error("memory::RunArena: append to a run that is closed or was never opened");
            Slab bigger = arena_->take(std::max<std::size_t>(2 * size_, 64));
            if (size_) std::copy(data_, data_ + size_, bigger.top);
            arena_->give_back(Slab{data_, end_});  // the old run's room is free again
            data_ = bigger.top;
            end_ = bigger.end;
        }
        RunArena* arena_ = nullptr;
        T* data_ = nullptr;
        T* end_ = nullptr;  ///< end of the slab the run holds while open
        std::size_t size_ = 0;
    };

    /// Blocks of `block_elements` T (at least 64; more where one run asks for more), from
    /// LargeAllocator: huge pages from kLargeBlock bytes on, carved cached blocks below (for
    /// arenas whose whole content is smaller than a huge page). Blocks mapped on other threads keep the page
    /// choice of a SmallPagesWhereCheap scope open on the thread that made the arena.
    explicit RunArena(std::size_t block_elements)
        : block_(std::max<std::size_t>(block_elements, 64)), scoped_(detail::small_pages_scopes() > 0) {}
    RunArena(const RunArena&) = delete;
    RunArena& operator=(const RunArena&) = delete;
    ~RunArena() {
        for (const Block& b : blocks_) LargeAllocator<T>().deallocate(b.p, b.n);
    }

    /// Opens a run on a slab with room for at least `expected` elements (it may grow past it).
    Run open(std::size_t expected) {
        Run r;
        Slab s = take(std::max<std::size_t>(expected, 1));
        r.arena_ = this;
        r.data_ = s.top;
        r.end_ = s.end;
        return r;
    }

    /// Closes a run: its unused room goes back to the arena. Closing a closed run does nothing.
    void close(Run& r) {
        if (!r.arena_) return;
        give_back(Slab{r.data_ + r.size_, r.end_});
        r.arena_ = nullptr;
        r.end_ = r.data_ + r.size_;
    }

    /// Blocks mapped so far (for tests and statistics).
    [[nodiscard]] std::size_t blocks() const {
        std::lock_guard lock(mutex_);
        return blocks_.size();
    }

private:
    struct Block {
        T* p;
        std::size_t n;
    };

    /// A slab with room for `n`: the free one with the least room that fits, else a new block.
    Slab take(std::size_t n) {
        {
            std::lock_guard lock(mutex_);
            auto best = free_.end();
            for (auto it = free_.begin(); it != free_.end(); ++it)
                if (static_cast<std::size_t>(it->end - it->top) >= n &&
                    (best == free_.end() || it->end - it->top < best->end - best->top))
                    best = it;
            if (best != free_.end()) {
                Slab s = *best;
                free_.erase(best);
                return s;
            }
        }
        const std::size_t count = std::max(n, block_);
        T* p;
        {
            std::optional<SmallPagesWhereCheap> scope;  // the arena maker's page choice, on this thread
            if (scoped_) scope.emplace();
            p = LargeAllocator<T>().allocate(count);
        }
        std::lock_guard lock(mutex_);
        try {
            blocks_.push_back({p, count});
        } catch (...) {
            LargeAllocator<T>().deallocate(p, count);
            throw;
        }
        return Slab{p, p + count};
    }

    /// Returns a slab's room; slivers (under 1/64 of a block) are dropped, and so is the room
    /// when the list cannot grow (nothing else is lost).
    void give_back(Slab s) noexcept {
        if (static_cast<std::size_t>(s.end - s.top) < block_ / 64) return;
        std::lock_guard lock(mutex_);
        try {
            free_.push_back(s);
        } catch (...) {
        }
    }

    const std::size_t block_;
    const bool scoped_;
    mutable std::mutex mutex_;
    std::vector<Block> blocks_;
    std::vector<Slab> free_;
};

/// A growing array that is either a LargeVector (a build on one thread: it can become the
/// result as it is) or a run of a RunArena (a parallel build: see RunArena for why). Its users
/// append, index and read the size the same way in both cases; start() picks which.
template <class T>
class RunOrVector {
public:
    /// Starts empty with room for about `expected` elements, in `arena` unless it is null.
    void start(RunArena<T>* arena, std::size_t expected) {
        arena_ = arena;
        if (arena_)
            run_ = arena_->open(expected);
        else
            vec_.reserve(expected);
    }
    T& emplace_back() { return arena_ ? run_.emplace_back() : vec_.emplace_back(); }
    /// Appends a copy of v (taken first: v may be an element of this array, which can move).
    void push_back(const T& v) {
        const T copy = v;
        emplace_back() = copy;
    }
    T& operator[](std::size_t i) { return arena_ ? run_[i] : vec_[i]; }
    const T& operator[](std::size_t i) const { return arena_ ? run_[i] : vec_[i]; }
    [[nodiscard]] std::size_t size() const { return arena_ ? run_.size() : vec_.size(); }
    /// No more elements: an arena run gives back its unused room (so that runs opened after
    /// this, on any thread, find it).
    void close() {
        if (arena_) arena_->close(run_);
    }
    [[nodiscard]] bool in_arena() const { return arena_ != nullptr; }
    /// The vector (empty for an array in an arena).
    std::vector<T, LargeAllocator<T>>& vector() { return vec_; }

private:
    RunArena<T>* arena_ = nullptr;
    typename RunArena<T>::Run run_;
    std::vector<T, LargeAllocator<T>> vec_;
};

/// Faults in the pages of the large block that the next LargeAllocator<T> allocation of n
/// elements will get, one write a 4 KiB page spread over the executor's threads, and hands the
/// block back to the cache, where that allocation (the same size: the best fit) finds it. For
/// a LargeVector about to be resized: its resize writes every element on one thread, and on
/// fresh memory the kernel zeroes each page in the fault of the thread that first writes it,
/// so without this one thread pays for all of the zeroing (on this project's machines up to
/// seconds for 140 MB, when the hypervisor has taken the memory back: README, "Known gaps").
/// Nothing happens for small blocks, a one-thread executor, or a cache without room for the
/// block (Config::cache_bytes; it would be given back to the system at once).
template <class T, Executor X>
void prefault(std::size_t n, X& exec) {
    if (n > SIZE_MAX / sizeof(T) || exec.concurrency() < 2) return;
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kLargeBlock || bytes > SIZE_MAX / 2) return;
    detail::LargeBlocks& blocks = detail::LargeBlocks::instance();
    if (blocks.stats().cached_bytes + bytes + kHugePage > blocks.config().cache_bytes) return;
    auto* p = static_cast<volatile unsigned char*>(blocks.allocate(bytes));
    const std::size_t page = 4096, pages = (bytes + page - 1) / page;
    try {
        exec.parallel_for(0, pages, 512, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t k = lo; k < hi; ++k) p[k * page] = 0;
        });
    } catch (...) {
        blocks.deallocate(const_cast<unsigned char*>(p));
        throw;
    }
    blocks.deallocate(const_cast<unsigned char*>(p));
}

}  // namespace sylva::memory

namespace sylva {
/// A std::vector whose storage comes from memory::LargeAllocator.
template <class T>
using LargeVector = std::vector<T, memory::LargeAllocator<T>>;
}  // namespace sylva

#endif  // SYLVA_CORE_MEMORY_HPP
