// SPDX-License-Identifier: MIT
// Executors: the sequential default and the std::thread pool cover [0, count) exactly once, propagate
// exceptions to the caller, and stay usable; the executor concept accepts and rejects the right types.

#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <aaf/executor.hpp>

namespace {

struct user_executor {  // any type with parallel_for(count, body) is an executor
    void parallel_for(std::size_t count, const std::function<void(std::size_t, std::size_t)>& body) {
        for (std::size_t i = 0; i < count; ++i) body(i, i + 1);
    }
};
struct no_parallel_for {
    void run(std::size_t, const std::function<void(std::size_t, std::size_t)>&) {}
};
struct wrong_signature {
    void parallel_for(int*) {}
};

struct my_error {
    int code;
};

/// Runs parallel_for(count) and checks every index was visited exactly once with valid, non-empty ranges.
template <class E>
void check_coverage(E& exec, std::size_t count, std::size_t max_chunk = 0) {
    CAPTURE(count, max_chunk);
    std::unique_ptr<std::atomic<int>[]> hits(new std::atomic<int>[count + 1]);
    for (std::size_t i = 0; i <= count; ++i) hits[i] = 0;
    std::atomic<int> bad_ranges{0}, calls{0};
    std::atomic<std::size_t> biggest{0};
    exec.parallel_for(count, [&](std::size_t b, std::size_t e) {
        ++calls;
        if (!(b < e && e <= count)) {
            ++bad_ranges;
            return;
        }
        std::size_t prev = biggest.load();
        while (e - b > prev && !biggest.compare_exchange_weak(prev, e - b)) {
        }
        for (std::size_t i = b; i < e; ++i) ++hits[i];
    });
    CHECK(bad_ranges == 0);
    int not_once = 0;
    for (std::size_t i = 0; i < count; ++i) not_once += hits[i] == 1 ? 0 : 1;
    CHECK(not_once == 0);
    CHECK(hits[count] == 0);
    if (count == 0) CHECK(calls == 0);
    if (max_chunk) CHECK(biggest <= max_chunk);
}

}  // namespace

static_assert(aaf::executor<aaf::sequential_executor>);
static_assert(aaf::executor<const aaf::sequential_executor>);
static_assert(aaf::executor<aaf::thread_pool>);
static_assert(aaf::executor<user_executor>);
static_assert(!aaf::executor<int>);
static_assert(!aaf::executor<no_parallel_for>);
static_assert(!aaf::executor<wrong_signature>);

TEST_CASE("executor: every index exactly once, for many counts and grains", "[executor]") {
    // Counts below, at and above the threads' number, and ones whose chunks do not split evenly over the
    // threads' shares (thread_pool: each thread's contiguous share, then the others').
    const std::size_t counts[] = {0, 1, 2, 3, 7, 13, 64, 1000, 1001};
    aaf::sequential_executor seq;
    user_executor user;
    constexpr std::size_t huge_grain = std::numeric_limits<std::size_t>::max() / 2 + 1;  // claims must not wrap
    aaf::thread_pool p1(1), p2(2), p3(3), p3g4(3, 4), p2g1000(2, 1000), p0(0), p3g0(3, 0), p2huge(2, huge_grain);
    CHECK(p1.size() == 1);
    CHECK(p2.size() == 2);
    CHECK(p3.size() == 3);
    CHECK(p0.size() >= 1);
    for (std::size_t n : counts) {
        check_coverage(seq, n);
        check_coverage(user, n, 1);
        check_coverage(p1, n, 1);
        check_coverage(p2, n, 1);
        check_coverage(p3, n, 1);
        check_coverage(p3g4, n, 4);
        check_coverage(p2g1000, n, 1000);
        check_coverage(p0, n, 1);
        check_coverage(p3g0, n, 1);  // grain 0 means 1
        check_coverage(p2huge, n, huge_grain);
    }
}

TEST_CASE("executor: thread_pool covers ranges whose chunks end near 2^64", "[executor]") {
    // count + grain > 2^64: a share's bounds computed as chunk·grain would wrap and skip items silently.
    constexpr std::size_t max = std::numeric_limits<std::size_t>::max(), half = max / 2 + 1;  // 2^64 − 1, 2^63
    struct case_ {
        std::size_t threads, grain, count;
    };
    for (const case_ c : {case_{1, half, max}, case_{2, half, max}, case_{2, half + 1, half + 2}, case_{3, max / 3 + 1, max},
                          case_{3, 1000, max - 5}}) {
        CAPTURE(c.threads, c.grain, c.count);
        aaf::thread_pool pool(c.threads, c.grain);
        std::mutex m;
        std::vector<std::pair<std::size_t, std::size_t>> ranges;
        const std::size_t limit = 16;  // the last case has ~1.8e16 chunks: stop after a few, via an exception
        bool stopped = false;
        try {
            pool.parallel_for(c.count, [&](std::size_t b, std::size_t e) {
                std::lock_guard lock(m);
                if (ranges.size() >= limit) throw std::length_error("enough");
                ranges.emplace_back(b, e);
            });
        } catch (const std::length_error&) {
            stopped = true;
        }
        const std::size_t chunks = (c.count - 1) / c.grain + 1;
        CHECK(stopped == (chunks > limit));
        std::sort(ranges.begin(), ranges.end());
        for (std::size_t i = 0; i < ranges.size(); ++i) {
            const auto [b, e] = ranges[i];
            CHECK(b < e);
            CHECK(e <= c.count);
            CHECK(b % c.grain == 0);
            CHECK((e - b == c.grain || e == c.count));
            if (i > 0) CHECK(ranges[i - 1].second <= b);  // disjoint
        }
        if (!stopped) {  // every item once: the sorted ranges tile [0, count)
            REQUIRE(ranges.size() == chunks);
            CHECK(ranges.front().first == 0);
            CHECK(ranges.back().second == c.count);
            for (std::size_t i = 1; i < ranges.size(); ++i) CHECK(ranges[i - 1].second == ranges[i].first);
        }
    }
}

TEST_CASE("executor: thread_pool(1) runs everything on the calling thread", "[executor]") {
    aaf::thread_pool pool(1);
    const auto me = std::this_thread::get_id();
    bool elsewhere = false;
    pool.parallel_for(50, [&](std::size_t, std::size_t) { elsewhere = elsewhere || std::this_thread::get_id() != me; });
    CHECK_FALSE(elsewhere);
}

TEST_CASE("executor: each thread_pool thread starts at its own share of the range", "[executor]") {
    // Every thread's first chunk waits until all threads have started one, so no thread can finish its own
    // share and take another's first chunk: the first chunks are then exactly the shares' starts, whatever
    // the scheduling. (The shares keep a thread's rows on its core from one stage to the next.)
    for (std::size_t threads : {2u, 3u}) {
        for (const bool hook : {false, true}) {  // with a start hook only the pool's own threads work
            CAPTURE(threads, hook);
            aaf::thread_pool pool = hook ? aaf::thread_pool(threads, 5, [](std::size_t) {}) : aaf::thread_pool(threads, 5);
            const std::size_t count = 90 * threads + 3;  // chunks of 5 items: 18·threads + 1 chunks
            std::atomic<std::size_t> started{0};
            std::atomic<bool> timed_out{false};
            std::vector<std::size_t> firsts;
            std::vector<std::thread::id> seen;  // threads that have started their first chunk
            std::mutex firsts_mutex;
            pool.parallel_for(count, [&](std::size_t b, std::size_t) {
                {
                    std::lock_guard lock(firsts_mutex);
                    if (std::find(seen.begin(), seen.end(), std::this_thread::get_id()) != seen.end()) return;
                    seen.push_back(std::this_thread::get_id());
                    firsts.push_back(b);
                }
                ++started;
                const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
                while (started.load() < threads)
                    if (std::chrono::steady_clock::now() > until) {
                        timed_out = true;
                        break;
                    }
            });
            CHECK_FALSE(timed_out);
            std::sort(firsts.begin(), firsts.end());
            // Shares of whole chunks: thread t's starts at chunk t·base + min(t, extra), base = chunks / threads,
            // extra = chunks % threads (the first `extra` shares one chunk longer).
            const std::size_t chunks = (count + 4) / 5;
            std::vector<std::size_t> expected;
            for (std::size_t t = 0, first = 0; t < threads; ++t) {
                expected.push_back(first * 5);
                first += chunks / threads + (t < chunks % threads ? 1 : 0);
            }
            CHECK(firsts == expected);
        }
    }
}

TEST_CASE("executor: exceptions reach the caller and the pool stays usable", "[executor]") {
    SECTION("sequential") {
        aaf::sequential_executor seq;
        CHECK_THROWS_WITH(seq.parallel_for(10, [](std::size_t, std::size_t) { throw std::runtime_error("boom"); }), "boom");
    }
    for (std::size_t threads : {1u, 2u, 3u}) {
        CAPTURE(threads);
        aaf::thread_pool pool(threads);
        // One chunk throws: that exception, with its type and message, reaches the caller.
        CHECK_THROWS_WITH(pool.parallel_for(100,
                                            [](std::size_t b, std::size_t e) {
                                                if (b <= 37 && 37 < e) throw std::runtime_error("boom at 37");
                                            }),
                          "boom at 37");
        check_coverage(pool, 1000, 1);
        // Every chunk throws (on every thread): exactly one exception comes out, of a non-std type.
        int caught = 0;
        try {
            pool.parallel_for(500, [](std::size_t b, std::size_t) { throw my_error{static_cast<int>(b)}; });
        } catch (const my_error& e) {
            ++caught;
            CHECK(e.code >= 0);
            CHECK(e.code < 500);
        }
        CHECK(caught == 1);
        check_coverage(pool, 7, 1);
        check_coverage(pool, 1000, 1);
        // Throwing again and again does not wedge it.
        for (int i = 0; i < 20; ++i)
            CHECK_THROWS_AS(pool.parallel_for(30, [](std::size_t, std::size_t) { throw std::logic_error("x"); }),
                            std::logic_error);
        check_coverage(pool, 64, 1);
    }
}

TEST_CASE("executor: a pool is reusable for many calls, also from several threads", "[executor]") {
    aaf::thread_pool pool(3);
    std::atomic<long> total{0};
    for (int call = 0; call < 200; ++call)
        pool.parallel_for(static_cast<std::size_t>(call % 17), [&](std::size_t b, std::size_t e) {
            total += static_cast<long>(e - b);
        });
    long expected = 0;
    for (int call = 0; call < 200; ++call) expected += call % 17;
    CHECK(total == expected);

    // Concurrent callers are serialised, and each still sees its own range covered once.
    std::atomic<int> failures{0};
    const auto caller = [&](std::size_t n) {
        for (int call = 0; call < 50; ++call) {
            std::vector<std::atomic<int>> hits(n);
            pool.parallel_for(n, [&](std::size_t b, std::size_t e) {
                for (std::size_t i = b; i < e; ++i) ++hits[i];
            });
            for (auto& h : hits)
                if (h != 1) ++failures;
        }
    };
    std::thread a(caller, 31), b(caller, 57);
    caller(13);
    a.join();
    b.join();
    CHECK(failures == 0);
}

TEST_CASE("executor: pools are created and destroyed cleanly", "[executor]") {
    for (int i = 0; i < 20; ++i) {
        aaf::thread_pool pool(static_cast<std::size_t>(1 + i % 4));
        if (i % 2) check_coverage(pool, static_cast<std::size_t>(i), 1);
    }
    SUCCEED("no deadlock at construction or destruction");
}
