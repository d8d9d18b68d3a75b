// sylva/core/executor.hpp -- parallel work: a serial executor and a thread pool that never
// leaks threads. Any type satisfying sylva::Executor (e.g. a wrapper over TBB) can replace them.
#ifndef SYLVA_CORE_EXECUTOR_HPP
#define SYLVA_CORE_EXECUTOR_HPP

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <type_traits>
#include <mutex>
#include <thread>
#include <vector>

#include "sylva/core/concepts.hpp"

namespace sylva {

/// Runs everything on the calling thread.
struct SerialExecutor {
    [[nodiscard]] std::size_t concurrency() const { return 1; }
    template <class F>
    void parallel_for(std::size_t begin, std::size_t end, std::size_t, F&& f) {
        if (begin < end) f(begin, end);
    }
    template <class F, class G>
    void invoke(F&& f, G&& g) {
        f();
        g();
    }
};

/// A fixed pool of worker threads.
///
/// Tasks are two words (a function pointer and a pointer to a job on the caller's stack), so
/// spawning allocates nothing per task. A caller waiting for its tasks runs queued tasks while
/// there are any (so nested parallelism, invoke inside invoke, cannot deadlock) and otherwise
/// waits until one of its tasks finishes or a task arrives. A waiting thread (a caller whose
/// tasks run elsewhere, an idle worker) first polls for up to `spin` (lock-free reads of the
/// group's count and the queue's size, a pause instruction between them, a yield every 16)
/// and only then blocks on the pool's condition variable: waking a blocked thread took about
/// 20 us on the project's 2-core VMs, a tenth of a 10^4-element WideTree build (README, "A
/// pool that polls before it sleeps"). parallel_for queues at most concurrency() - 1 helper
/// tasks that take the range's chunks from an atomic counter, the caller taking them too.
/// Exceptions: the first one thrown by a chunk or a callable is rethrown to the caller after
/// every task of the call has finished, and a failure to queue a task (std::bad_alloc) still
/// waits for the tasks already queued before it propagates, so no queued task outlives the
/// stack it points to. Threads are joined in the destructor.
class ThreadPool {
public:
    /// How long a waiting thread polls before it blocks, by default. 200 us: on two threads,
    /// building back to back, the 10^4-sphere clustered WideTree build took 0.74-0.85 ms
    /// without polling, 0.65-0.80 with 50 us and 0.62-0.77 with 200 us; 10^6 uniform 57-68
    /// against 55-57 ms (throw-away probe, alternated processes; README, "A pool that polls
    /// before it sleeps").
    static constexpr std::chrono::microseconds kDefaultSpin{200};

    /// `threads` = 0 uses std::thread::hardware_concurrency(); `spin` = 0 blocks at once (no
    /// polling: for pools that share their cores with other busy work).
    explicit ThreadPool(std::size_t threads = 0, std::chrono::microseconds spin = kDefaultSpin)
        : spin_ns_(static_cast<std::uint64_t>(std::max<std::int64_t>(0, std::chrono::nanoseconds(spin).count()))) {
        std::size_t n = threads ? threads : std::max<std::size_t>(1, std::thread::hardware_concurrency());
        try {
            for (std::size_t i = 1; i < n; ++i) workers_.emplace_back([this] { work(); });
        } catch (...) {
            stop();
            throw;
        }
    }
    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;
    ~ThreadPool() { stop(); }

    [[nodiscard]] std::size_t concurrency() const { return workers_.size() + 1; }

    /// Wakes the workers that sleep, so that they poll for work (for up to `spin`) instead of
    /// waiting for the first push to wake them: a caller about to fork work (bih::build) calls
    /// it before its own serial start, so that the workers' wake-up overlaps that work. Why: a
    /// blocked thread on these VMs, whose idle vCPUs halt at once (cpuidle haltpoll with
    /// guest_halt_poll_ns 0), woke 30-60 us (medians) after the notify when the notifying
    /// thread had waited busy for 2 ms, and 1-4 ms when it too had slept 2-100 ms (throw-away
    /// probe, 20 wakes each; README, "A longer queue, and workers woken early"). Optional for
    /// executors: the builders call it where a type has it. Does nothing for a pool that does
    /// not poll (`spin` = 0).
    void wake_workers() {
        if (spin_ns_ == 0 || workers_.empty()) return;
        {
            std::lock_guard lock(mutex_);
            ++wake_hints_;
        }
        wake_.notify_all();
    }

    template <class F>
    void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, F&& f) {
        if (begin >= end) return;
        grain = std::max<std::size_t>(grain, 1);
        std::size_t chunks = std::min((end - begin + grain - 1) / grain, concurrency() * 4);
        if (chunks <= 1) {
            f(begin, end);
            return;
        }
        Group group(*this);
        RangeJob<std::remove_reference_t<F>> job{&f, &group, begin, end, (end - begin + chunks - 1) / chunks, {begin}};
        std::size_t helpers = std::min(chunks, concurrency()) - 1;
        for (std::size_t i = 0; i < helpers; ++i) group.spawn(&RangeJob<std::remove_reference_t<F>>::run, &job);
        job.drain();
        group.wait();
    }

    template <class F, class G>
    void invoke(F&& f, G&& g) {
        Group group(*this);
        CallJob<std::remove_reference_t<G>> job{&g, &group};
        group.spawn(&CallJob<std::remove_reference_t<G>>::run, &job);
        group.run_here(f);
        group.wait();
    }

private:
    /// A queued task: run(ctx).
    struct Task {
        void (*run)(void*);
        void* ctx;
    };

    /// A set of tasks a caller waits for; the first exception is rethrown by wait(). The
    /// destructor waits too, so an exception between spawn and wait (a failed spawn) cannot
    /// leave a queued task pointing at a dead group or job.
    class Group {
    public:
        explicit Group(ThreadPool& pool) : pool_(pool) {}
        Group(const Group&) = delete;
        Group& operator=(const Group&) = delete;
        ~Group() { pool_.wait_until_zero(pending_); }

        void spawn(void (*run)(void*), void* ctx) {
            pending_.fetch_add(1, std::memory_order_relaxed);
            try {
                pool_.push(Task{run, ctx});
            } catch (...) {
                pending_.fetch_sub(1, std::memory_order_relaxed);
                throw;
            }
        }
        /// Marks one spawned task done (called by the task itself, last).
        void finish_one() {
            ThreadPool& pool = pool_;  // the group may be gone once the count reaches zero
            if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) pool.notify_waiters();
        }
        template <class F>
        void run_here(F& f) {
            try {
                f();
            } catch (...) {
                std::lock_guard lock(error_mutex_);
                if (!error_) error_ = std::current_exception();
            }
        }
        void wait() {
            pool_.wait_until_zero(pending_);
            if (error_) std::rethrow_exception(error_);
        }

    private:
        ThreadPool& pool_;
        std::atomic<std::size_t> pending_{0};
        std::mutex error_mutex_;
        std::exception_ptr error_;
    };

    /// parallel_for's job: chunks of `step` taken from `next` until the range is done.
    template <class F>
    struct RangeJob {
        F* f;
        Group* group;
        std::size_t begin, end, step;
        std::atomic<std::size_t> next;

        void drain() {
            for (;;) {
                std::size_t lo = next.fetch_add(step, std::memory_order_relaxed);
                if (lo >= end) return;
                std::size_t hi = std::min(end, lo + step);
                auto chunk = [this, lo, hi] { (*f)(lo, hi); };
                group->run_here(chunk);
            }
        }
        static void run(void* self) {
            auto* job = static_cast<RangeJob*>(self);
            job->drain();
            job->group->finish_one();
        }
    };

    /// invoke's second callable as a task.
    template <class G>
    struct CallJob {
        G* g;
        Group* group;
        static void run(void* self) {
            auto* job = static_cast<CallJob*>(self);
            job->group->run_here(*job->g);
            job->group->finish_one();
        }
    };

    void push(Task task) {
        {
            std::lock_guard lock(mutex_);
            queue_.push_back(task);
            queued_.store(queue_.size(), std::memory_order_release);
        }
        wake_.notify_one();
    }
    /// Polls `ready` (which reads only atomics) for up to spin_ns_; true when it held.
    template <class Ready>
    bool poll(Ready&& ready) const {
        if (spin_ns_ == 0) return false;
        using Clock = std::chrono::steady_clock;
        const Clock::time_point start = Clock::now();
        for (unsigned i = 1;; ++i) {
            if (ready()) return true;
            pause();
            if (i % 16 == 0) {
                if (static_cast<std::uint64_t>(std::chrono::nanoseconds(Clock::now() - start).count()) > spin_ns_)
                    return false;
                // Lets a thread that shares this core run: after the caller slept, the kernel
                // may wake a worker onto the caller's core, and a poll that kept the core would
                // stall the caller for the whole spin (the BIH of a 10^4-sphere WideTree, each
                // build after a 2 ms sleep: 0.79 ms without the yield, 0.57 with it, 0.59
                // without polling; README, "A pool that polls before it sleeps").
                std::this_thread::yield();
            }
        }
    }
    static void pause() {
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();  // spin-wait hint: yields the core's resources, saves power
#elif defined(__aarch64__)
        asm volatile("yield");
#endif
    }
    /// Wakes every thread blocked in the pool (a group finished: its waiter may be asleep).
    void notify_waiters() {
        { std::lock_guard lock(mutex_); }  // orders the notify after the waiter's predicate check
        wake_.notify_all();
    }
    /// Runs queued tasks while `pending` is not zero, blocking when the queue is empty.
    void wait_until_zero(const std::atomic<std::size_t>& pending) {
        if (pending.load(std::memory_order_acquire) == 0) return;
        std::unique_lock lock(mutex_);
        while (pending.load(std::memory_order_acquire) != 0) {
            if (queue_.empty()) {
                lock.unlock();
                const bool ready = poll([&] {
                    return pending.load(std::memory_order_acquire) == 0 || queued_.load(std::memory_order_acquire) != 0;
                });
                lock.lock();
                // Checked again under the lock: a task finishing after this check notifies
                // under the lock (notify_waiters), so it cannot slip between check and wait.
                if (!ready && queue_.empty() && pending.load(std::memory_order_acquire) != 0) wake_.wait(lock);
                continue;
            }
            Task task = queue_.back();  // the newest: most likely this caller's own (nested) work
            queue_.pop_back();
            queued_.store(queue_.size(), std::memory_order_release);
            lock.unlock();
            task.run(task.ctx);
            lock.lock();
        }
        // A push's notify_one may have woken this caller just as its count reached zero: pass
        // the wake-up on so a queued task does not wait for a sleeping worker.
        if (!queue_.empty()) wake_.notify_one();
    }
    void work() {
        std::unique_lock lock(mutex_);
        std::uint64_t hints = wake_hints_;
        for (;;) {
            if (queue_.empty() && !stopping_) {
                lock.unlock();
                (void)poll([this] {
                    return queued_.load(std::memory_order_acquire) != 0 || stopping_.load(std::memory_order_acquire);
                });
                lock.lock();
            }
            wake_.wait(lock, [&] { return stopping_ || !queue_.empty() || wake_hints_ != hints; });
            hints = wake_hints_;
            if (queue_.empty()) {
                if (stopping_) return;  // stopping, nothing left
                continue;               // woken by wake_workers(): poll for the work to come
            }
            Task task = queue_.front();
            queue_.pop_front();
            queued_.store(queue_.size(), std::memory_order_release);
            lock.unlock();
            task.run(task.ctx);
            lock.lock();
        }
    }
    void stop() {
        {
            std::lock_guard lock(mutex_);
            stopping_.store(true, std::memory_order_release);
        }
        wake_.notify_all();
        for (auto& w : workers_) w.join();
    }

    std::vector<std::thread> workers_;
    std::uint64_t spin_ns_;
    std::deque<Task> queue_;
    /// queue_.size(), written under mutex_, read by polling threads without it (its own cache
    /// line, so that their reads do not contend with the lock's word).
    alignas(64) std::atomic<std::size_t> queued_{0};
    alignas(64) std::mutex mutex_;
    std::condition_variable wake_;
    std::uint64_t wake_hints_ = 0;  ///< wake_workers() calls so far; under mutex_
    std::atomic<bool> stopping_{false};  ///< written under mutex_; polled without it
};

static_assert(Executor<SerialExecutor>);
static_assert(Executor<ThreadPool>);

/// Rows of a frame a renderer's thread takes at a time (parallel_take's block): two rows are a
/// thousand rays or more (0.3-0.7 ms of a thread's time in an isosurface frame of 512^2),
/// against one counter increment.
inline constexpr std::size_t kRowsPerTake = 2;

/// Calls f(lo, hi) on consecutive blocks of `block` items (block 0 counts as 1; the last block
/// shorter) covering [begin, end), each block taken from a shared counter by whichever of
/// exec.concurrency() tasks is free, so that items whose cost varies (a frame's rows: the sky
/// is cheap, the surface is not) are shared out evenly. parallel_for's chunks are fixed
/// (ThreadPool: at most four a thread, a 512-row frame in 8 chunks of 64), and the thread left
/// with the costliest chunk finished last. The renderers take their rows this way: on two
/// threads the implicit kd-tree's single rays at Marschner-Lobb 512^3 ran 3-5 % faster (32^3
/// 1-2 %), side by side (README, Wald section, "Rows taken as threads free up"). Works with any
/// Executor; f runs on several threads at once, on disjoint blocks. An exception from f reaches
/// the caller as parallel_for's do (ThreadPool: once every task has finished).
template <Executor X, class F>
void parallel_take(X& exec, std::size_t begin, std::size_t end, std::size_t block, F&& f) {
    if (begin >= end) return;
    block = std::max<std::size_t>(block, 1);
    const std::size_t blocks = (end - begin + block - 1) / block;
    const std::size_t tasks = std::max<std::size_t>(1, std::min<std::size_t>(exec.concurrency(), blocks));
    std::atomic<std::size_t> next{0};
    exec.parallel_for(0, tasks, 1, [&](std::size_t t0, std::size_t t1) {
        for (std::size_t t = t0; t < t1; ++t)
            for (std::size_t b; (b = next.fetch_add(1, std::memory_order_relaxed)) < blocks;) {
                const std::size_t lo = begin + b * block;
                f(lo, std::min(lo + block, end));
            }
    });
}

}  // namespace sylva

#endif  // SYLVA_CORE_EXECUTOR_HPP
