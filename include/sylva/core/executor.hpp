// sylva/core/executor.hpp -- parallel work: a serial executor and a thread pool that never
// leaks threads. Any type satisfying sylva::Executor (e.g. a wrapper over TBB) can replace them.
#ifndef SYLVA_CORE_EXECUTOR_HPP
#define SYLVA_CORE_EXECUTOR_HPP

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
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

/// A fixed pool of worker threads. Waiting callers help run queued tasks, so nested
/// parallelism (invoke inside invoke) cannot deadlock. Threads are joined in the destructor.
class ThreadPool {
public:
    /// `threads` = 0 uses std::thread::hardware_concurrency().
    explicit ThreadPool(std::size_t threads = 0) {
        std::size_t n = threads ? threads : std::max<std::size_t>(1, std::thread::hardware_concurrency());
        for (std::size_t i = 1; i < n; ++i) workers_.emplace_back([this] { work(); });
    }
    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;
    ~ThreadPool() {
        {
            std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        wake_.notify_all();
        for (auto& w : workers_) w.join();
    }

    [[nodiscard]] std::size_t concurrency() const { return workers_.size() + 1; }

    template <class F>
    void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, F&& f) {
        if (begin >= end) return;
        grain = std::max<std::size_t>(grain, 1);
        std::size_t chunks = std::min((end - begin + grain - 1) / grain, concurrency() * 4);
        if (chunks <= 1) {
            f(begin, end);
            return;
        }
        std::size_t step = (end - begin + chunks - 1) / chunks;
        Group group(*this);
        for (std::size_t lo = begin; lo < end; lo += step) {
            std::size_t hi = std::min(end, lo + step);
            group.spawn([&f, lo, hi] { f(lo, hi); });
        }
        group.wait();
    }

    template <class F, class G>
    void invoke(F&& f, G&& g) {
        Group group(*this);
        group.spawn([&g] { g(); });
        group.run_here([&f] { f(); });
        group.wait();
    }

private:
    /// A set of tasks a caller waits for; the first exception is rethrown by wait().
    class Group {
    public:
        explicit Group(ThreadPool& pool) : pool_(pool) {}
        template <class F>
        void spawn(F&& f) {
            pending_.fetch_add(1);
            pool_.push([this, f = std::forward<F>(f)]() mutable { run_here(f); pending_.fetch_sub(1); });
        }
        template <class F>
        void run_here(F&& f) {
            try {
                f();
            } catch (...) {
                std::lock_guard lock(error_mutex_);
                if (!error_) error_ = std::current_exception();
            }
        }
        void wait() {
            while (pending_.load() != 0) {
                if (!pool_.run_one()) std::this_thread::yield();
            }
            if (error_) std::rethrow_exception(error_);
        }

    private:
        ThreadPool& pool_;
        std::atomic<std::size_t> pending_{0};
        std::mutex error_mutex_;
        std::exception_ptr error_;
    };

    void push(std::function<void()> task) {
        {
            std::lock_guard lock(mutex_);
            queue_.push_back(std::move(task));
        }
        wake_.notify_one();
    }
    /// Runs one queued task on the calling thread; false when the queue was empty.
    bool run_one() {
        std::function<void()> task;
        {
            std::lock_guard lock(mutex_);
            if (queue_.empty()) return false;
            task = std::move(queue_.back());
            queue_.pop_back();
        }
        task();
        return true;
    }
    void work() {
        for (;;) {
            std::function<void()> task;
            {
                std::unique_lock lock(mutex_);
                wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
                if (stopping_ && queue_.empty()) return;
                task = std::move(queue_.front());
                queue_.pop_front();
            }
            task();
        }
    }

    std::vector<std::thread> workers_;
    std::deque<std::function<void()>> queue_;
    std::mutex mutex_;
    std::condition_variable wake_;
    bool stopping_ = false;
};

static_assert(Executor<SerialExecutor>);
static_assert(Executor<ThreadPool>);

}  // namespace sylva

#endif  // SYLVA_CORE_EXECUTOR_HPP
