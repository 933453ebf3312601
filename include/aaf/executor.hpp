// SPDX-License-Identifier: MIT
#pragma once
// Executors: who runs the rows. A sequential default, a std::thread pool made once, or the caller's own.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <concepts>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace aaf {
inline namespace v0 {

/// An executor runs `body(begin, end)` over disjoint sub-ranges covering [0, count) and returns when all
/// are done. Sub-ranges may run concurrently and in any order; aaf's results never depend on either
/// (every pixel's samples are keyed by the pixel, not by the thread). Exceptions thrown by `body` must
/// reach the caller of `parallel_for`.
///
/// Per-thread set-up (e.g. the FTZ/DAZ floating-point modes Embree asks for on tracing threads, or a
/// tracer's per-thread context) is the executor's: `thread_pool` takes a start hook that runs once on each
/// of its threads before any work; an executor of your own runs yours on its threads. aaf's arithmetic
/// is FTZ/DAZ-safe: with denormals flushed, frames differ from the IEEE ones only where a weight or
/// distance is itself denormal (test_embedding.cpp measures it; README "Threads").
template <class E>
concept executor = requires(E& e, std::size_t count, std::function<void(std::size_t, std::size_t)> body) {
    { e.parallel_for(count, body) };
};

/// Optionally an executor says how many bodies it runs at once, as `concurrency()` (thread_pool: its
/// threads; sequential_executor: 1). A stage whose tasks read a halo of rows around their own (spread_slopes)
/// then cuts the image into that many bands instead of many small ones. Without it (0 = unknown) the stage
/// keeps its fixed band size; results never depend on it.
template <class E>
[[nodiscard]] std::size_t concurrency_of(const E& e) noexcept {
    if constexpr (requires { { e.concurrency() } -> std::convertible_to<std::size_t>; }) return static_cast<std::size_t>(e.concurrency());
    else return 0;
}

/// Runs everything on the calling thread. The default.
struct sequential_executor {
    template <class Body>
    void parallel_for(std::size_t count, Body&& body) const {
        if (count > 0) body(std::size_t{0}, count);
    }
    [[nodiscard]] static constexpr std::size_t concurrency() noexcept { return 1; }
};

/// A fixed pool of std::threads created once (never per call), plus the calling thread, which works too.
/// `parallel_for` hands out chunks of `grain` items, so rows of uneven cost balance: each thread takes the
/// chunks of its own contiguous share of [0, count) through a counter of its own, then those left in the
/// others' shares. (One counter for all threads cost an atomic operation on a line every thread writes,
/// ~0.3 µs per chunk between the 2 cores of a VM: a 720-row copy took 2.5x as long on 2 threads as on 1,
/// issue 14. A thread's own share also keeps the same rows on the same core from one stage to the next.)
/// One `parallel_for` runs at a time per pool (concurrent callers are serialised); calling it from inside
/// a body of the same pool deadlocks, so don't.
/// Between calls the threads wait for work by polling for up to `spin_time` before they block on a
/// condition variable, and the caller polls as long for the last chunks to finish: a frame's stages are
/// consecutive `parallel_for` calls a few microseconds apart, and waking a blocked thread (a futex wake,
/// an inter-processor interrupt, in a VM a hypervisor exit) took tens of microseconds each time, a
/// serial part of every call (issue 14: spread_slopes's passes are a few milliseconds each).
class thread_pool {
public:
    /// `threads` = total threads including the caller; 0 = std::thread::hardware_concurrency().
    explicit thread_pool(std::size_t threads = 0, std::size_t grain = 1) : grain_(std::max<std::size_t>(grain, 1)) {
        if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
        start(threads - 1, {});
    }

    /// A pool whose `threads` threads (0 = hardware_concurrency) each call `on_start(i)`, i in [0, threads),
    /// once before any work, e.g. to set FTZ/DAZ or bind a tracer's per-thread state. Every chunk of work
    /// then runs on a thread that has run it: the caller of parallel_for only waits (its own thread's modes
    /// are left alone). `on_start` must not throw (it runs on a std::thread).
    thread_pool(std::size_t threads, std::size_t grain, std::function<void(std::size_t)> on_start)
        : grain_(std::max<std::size_t>(grain, 1)), caller_works_(!on_start) {
        if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
        start(caller_works_ ? threads - 1 : threads, std::move(on_start));
    }
    thread_pool(const thread_pool&) = delete;
    thread_pool& operator=(const thread_pool&) = delete;
    ~thread_pool() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
        for (auto& w : workers_) w.join();
    }

    [[nodiscard]] std::size_t size() const noexcept { return workers_.size() + (caller_works_ ? 1 : 0); }
    /// The threads that run bodies at once (= size(); see concurrency_of).
    [[nodiscard]] std::size_t concurrency() const noexcept { return size(); }

    /// How long an idle thread polls for the next call (and the caller for the last chunks) before it
    /// blocks: long enough to bridge the gap between a frame's consecutive calls, short enough that an
    /// idle pool costs no CPU time to speak of.
    static constexpr std::chrono::microseconds spin_time{100};

    template <class Body>
    void parallel_for(std::size_t count, Body&& body) {
        if (count == 0) return;
        std::lock_guard call_lock(call_mutex_);
        std::function<void(std::size_t, std::size_t)> job = [&body](std::size_t b, std::size_t e) { body(b, e); };
        {
            std::lock_guard lock(mutex_);
            job_ = &job;
            // Thread t's share: `base` chunks of grain items (base + 1 for the first `extra` threads) from chunk
            // t·base + min(t, extra). `item(c)` is chunk c's first item, never computed past `count` (c·grain
            // wraps for c = chunks when count + grain > 2^64).
            const std::size_t n = size(), chunks = (count - 1) / grain_ + 1, base = chunks / n, extra = chunks % n;
            const auto item = [&](std::size_t c) { return c >= chunks ? count : c * grain_; };
            for (std::size_t t = 0; t < n; ++t) {
                const std::size_t first = t * base + std::min(t, extra), last = first + base + (t < extra ? 1 : 0);
                shares_[t].next.store(item(first));
                shares_[t].end = item(last);
            }
            error_ = nullptr;
            busy_.store(workers_.size());
            generation_.store(generation_.load() + 1);
        }
        wake_.notify_all();
        if (caller_works_) run_chunks(0);
        spin([this] { return busy_.load() == 0; });
        std::unique_lock lock(mutex_);
        done_.wait(lock, [this] { return busy_.load() == 0; });
        job_ = nullptr;
        if (error_) std::rethrow_exception(error_);
    }

private:
    void start(std::size_t workers, std::function<void(std::size_t)> on_start) {
        shares_ = std::make_unique<share[]>(caller_works_ ? workers + 1 : workers);
        workers_.reserve(workers);
        for (std::size_t i = 0; i < workers; ++i)
            workers_.emplace_back([this, i, on_start] {
                if (on_start) on_start(i);
                worker_loop(caller_works_ ? i + 1 : i);
            });
    }

    /// Runs the chunks of thread `self`'s share, then those still left in the others' shares. A claim never
    /// moves a share's counter past its end (a counter added to blindly wraps with a grain near 2^64).
    void run_chunks(std::size_t self) {
        const std::size_t n = size();
        for (std::size_t k = 0; k < n; ++k) {
            share& s = shares_[(self + k) % n];
            for (;;) {
                std::size_t begin = s.next.load(), end = 0;
                do {
                    if (begin >= s.end) break;
                    end = begin + std::min(grain_, s.end - begin);
                } while (!s.next.compare_exchange_weak(begin, end));
                if (begin >= s.end) break;
                try {
                    (*job_)(begin, end);
                } catch (...) {
                    std::lock_guard lock(mutex_);
                    if (!error_) error_ = std::current_exception();
                    for (std::size_t t = 0; t < n; ++t) shares_[t].next.store(shares_[t].end);  // stop handing out work
                }
            }
        }
    }

    /// Polls `ready` for up to spin_time (the caller then blocks on a condition variable if it is still
    /// false). The clock is read every 64 polls; the pause instruction lets a sibling hyperthread run.
    template <class Ready>
    static void spin(Ready&& ready) noexcept {
        const auto until = std::chrono::steady_clock::now() + spin_time;
        for (;;) {
            for (int i = 0; i < 64; ++i) {
                if (ready()) return;
#if defined(__x86_64__) || defined(__i386__)
                __builtin_ia32_pause();
#endif
            }
            if (std::chrono::steady_clock::now() >= until) return;
        }
    }

    void worker_loop(std::size_t self) {
        std::size_t seen = 0;
        for (;;) {
            spin([&] { return generation_.load() != seen; });
            {
                std::unique_lock lock(mutex_);
                wake_.wait(lock, [&] { return stop_ || generation_.load() != seen; });
                if (stop_) return;
                seen = generation_.load();
            }
            run_chunks(self);
            {
                std::lock_guard lock(mutex_);
                --busy_;
            }
            done_.notify_one();
        }
    }

    std::size_t grain_;
    bool caller_works_ = true;  // false with a start hook: only hooked threads run chunks
    std::vector<std::thread> workers_;
    std::mutex call_mutex_;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::condition_variable done_;
    std::function<void(std::size_t, std::size_t)>* job_ = nullptr;
    /// One thread's share of a call's chunks: the next item to hand out and the share's end. A cache line
    /// each, so that a thread's claims in its own share touch no line another thread writes.
    struct alignas(64) share {
        std::atomic<std::size_t> next{0};
        std::size_t end = 0;  // written before the call is published, read-only during it
    };
    std::unique_ptr<share[]> shares_;  // size() of them: the caller's (if it works) first, then the workers'
    std::exception_ptr error_;
    std::atomic<std::size_t> busy_{0};        // written under mutex_, polled without it (spin)
    std::atomic<std::size_t> generation_{0};  // likewise
    bool stop_ = false;
};

static_assert(executor<sequential_executor>);
static_assert(executor<thread_pool>);

namespace detail {

template <class Signature>
class function_ref;

/// A non-owning reference to a callable (a pointer to it and a pointer to a function that calls it): the
/// pipeline's stages take callbacks through it instead of as template parameters, so that they are compiled
/// once per pixel type, not once per caller's lambda, progress callback or executor type. The callable must
/// outlive the reference.
template <class R, class... Args>
class function_ref<R(Args...)> {
public:
    template <class F>
        requires(!std::is_same_v<std::remove_cvref_t<F>, function_ref> && std::is_invocable_r_v<R, F&, Args...>)
    function_ref(F&& f) noexcept  // NOLINT: implicit, like std::function_ref
        : object_(const_cast<void*>(static_cast<const void*>(std::addressof(f)))), call_(&call<std::remove_reference_t<F>>) {}

    R operator()(Args... args) const { return call_(object_, std::forward<Args>(args)...); }

private:
    template <class F>
    static R call(void* f, Args... args) {
        return static_cast<R>((*static_cast<F*>(f))(std::forward<Args>(args)...));
    }
    void* object_;
    R (*call_)(void*, Args...);
};

/// A non-owning, type-erased reference to an executor, itself an executor: `parallel_for` hands the body to
/// the referenced executor's `parallel_for` (as a callable taking (begin, end)). One indirect call per
/// sub-range, never per pixel. The stages that do not touch the tracer (statistics, formulas, spreading,
/// filter, outputs) take it, so that a program compiles them once whatever executors it uses, and so that
/// the compiled mode (AAF_EXTERN_TEMPLATES, aaf::compiled) can hold them for every executor.
class executor_ref {
public:
    template <class E>
        requires(!std::is_same_v<std::remove_cvref_t<E>, executor_ref>)
    executor_ref(E& exec) noexcept  // NOLINT: implicit, so that an executor converts where a stage takes one
        : exec_(const_cast<void*>(static_cast<const void*>(std::addressof(exec)))), run_(&run<E>), concurrency_(concurrency_of(exec)) {}

    template <class Body>
    void parallel_for(std::size_t count, Body&& body) const {
        run_(exec_, count, function_ref<void(std::size_t, std::size_t)>(body));
    }
    /// The referenced executor's concurrency_of (0 = it does not say).
    [[nodiscard]] std::size_t concurrency() const noexcept { return concurrency_; }

private:
    using body_ref = function_ref<void(std::size_t, std::size_t)>;
    template <class E>
    static void run(void* exec, std::size_t count, body_ref body) {
        static_cast<E*>(exec)->parallel_for(count, [body](std::size_t begin, std::size_t end) { body(begin, end); });
    }
    void* exec_;
    void (*run_)(void*, std::size_t, body_ref);
    std::size_t concurrency_;
};

static_assert(executor<executor_ref>);

}  // namespace detail

}  // namespace v0
}  // namespace aaf
