// SPDX-License-Identifier: MIT
// filter_visibility with a caller's filter_workspace: a frame loop's repeated calls allocate nothing once
// the workspace has served a frame of that size, and the results are the bits of the call without one.
//
// Allocations are counted by replacing the global operator new/delete of this test executable (they
// forward to malloc/free, so they change nothing else); the counter only matters while a test reads it.

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>

#include <aaf/filter.hpp>
#include <aaf/image.hpp>

// GCC sees the replacement delete (free) inlined next to a new-expression and warns of a mismatch: here
// both sides are the replacements below, malloc and free, so they match.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

namespace {
std::atomic<std::uint64_t> allocations{0};
}  // namespace

void* operator new(std::size_t n) {
    allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n > 0 ? n : 1)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return ::operator new(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
// The nothrow forms too (std::stable_sort's temporary buffer uses them): with only the plain forms replaced,
// a sanitizer's own nothrow new would be paired with the free() above (ASan: alloc-dealloc-mismatch).
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
    allocations.fetch_add(1, std::memory_order_relaxed);
    return std::malloc(n > 0 ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return ::operator new(n, t); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

namespace {

/// Runs `body` on chunks of 3 items, in order, without allocating (unlike a std::function-based pool):
/// several tasks, so several of the workspace's per-task buffers are exercised.
struct chunked_executor {
    template <class Body>
    void parallel_for(std::size_t count, Body&& body) const {
        for (std::size_t b = 0; b < count; b += 3) body(b, std::min(count, b + 3));
    }
};

struct frame {
    std::size_t w, h;
    aaf::image<float> vis, beta, d;
    aaf::image<glm::vec3> n, p;
    aaf::image<std::uint32_t> id;
    frame(std::size_t w_, std::size_t h_) : w(w_), h(h_), vis(w_, h_), beta(w_, h_), d(w_, h_, 0.01f), n(w_, h_), p(w_, h_), id(w_, h_) {
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float fx = static_cast<float>(x), fy = static_cast<float>(y);
                vis(x, y) = 0.5f + 0.5f * std::sin(0.3f * fx) * std::cos(0.2f * fy);
                beta(x, y) = 0.01f * (1.0f + 4.0f * (0.5f + 0.5f * std::sin(0.05f * fx + 0.07f * fy)));
                n(x, y) = glm::normalize(glm::vec3(0.2f * std::sin(0.1f * fx), 1.0f, 0.0f));
                p(x, y) = {0.01f * fx, 0.0f, 0.01f * fy};
                id(x, y) = static_cast<std::uint32_t>((x / 40 + y / 30) % 2);
            }
        vis(3, 4) = std::nanf("");  // a non-finite centre: the scalar rule runs too
    }
};

}  // namespace

TEST_CASE("filter: a repeated call with a filter_workspace allocates nothing and gives the same bits", "[filter][workspace]") {
    const frame f(150, 400);  // 400 rows: several 64-row tasks
    const aaf::guides g{f.n.cview(), f.id.cview(), f.p.cview()};
    for (const auto space : {aaf::offset_space::image, aaf::offset_space::light_plane}) {
        INFO((space == aaf::offset_space::image ? "image space" : "light plane"));
        aaf::filter_settings<float> s;
        s.space = space;
        aaf::image<float> out(f.w, f.h), scratch(f.w, f.h), expected(f.w, f.h), expected_scratch(f.w, f.h);
        aaf::filter_visibility<float>(f.vis.cview(), f.beta.cview(), f.d.cview(), expected.view(), expected_scratch.view(),
                                      g, s, {0.f, 1.f, 0.f}, chunked_executor{});
        aaf::filter_workspace<float> ws;
        const auto run = [&] {
            aaf::filter_visibility<float>(f.vis.cview(), f.beta.cview(), f.d.cview(), out.view(), scratch.view(), ws, g, s,
                                          {0.f, 1.f, 0.f}, chunked_executor{});
        };
        run();  // the workspace grows to this frame
        const std::uint64_t before = allocations.load();
        run();
        run();
        CHECK(allocations.load() == before);
        CHECK(std::memcmp(out.data(), expected.data(), out.size() * sizeof(float)) == 0);
    }
}
