// SPDX-License-Identifier: MIT
// libFuzzer harness: filter_visibility and spread_slopes on small images (up to 24x24) with arbitrary
// strides, every combination of guides, both offset spaces, and arbitrary β, pixel sizes, normals,
// positions, IDs and visibility values (NaN, ±Inf and denormals included), in float and double.
//
// Settings and buffers are validated by the library first; an aaf::invalid_argument is not a finding.
//
// Invariants of filter_visibility (any violation aborts):
// * every output pixel whose input is finite is finite and lies in [min, max] of the finite inputs (a
//   weighted mean; rounding allowed for); an output pixel whose input is not finite is either such a mean
//   (its neighbours' average) or its input, bit for bit (it had no usable neighbour);
// * nothing outside the output view is written (the bytes between strided pixels and rows are untouched).
// Finite visibility values are kept within ±1e30 (float) / ±1e300 (double): the weighted sum of a window
// of values near the largest T can overflow, which is outside the domain of a visibility filter.
// Invariants of spread_slopes:
// * occluded pixels keep their slopes bit for bit; every other pixel gets the no-occluder identity or the
//   max s1 / min s2 of occluded pixels; without IDs exactly those of its (2r+1)^2 window (brute force);
// * nothing outside the views is written.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <aaf/filter.hpp>
#include <aaf/guides.hpp>
#include <aaf/image_view.hpp>
#include <aaf/occlusion_stats.hpp>
#include <aaf/settings.hpp>

#include "fuzz_input.hpp"

namespace {

constexpr unsigned char sentinel = 0xA5;

/// A view over its own byte buffer with fuzzed strides: pixel stride sizeof(U) + pad (pad in bytes, any
/// value, so misaligned layouts are tried too), and a row stride with extra padding.
template <class U>
struct strided {
    std::vector<unsigned char> bytes;
    std::size_t w = 0, h = 0, pixel = 0, row = 0, offset = 0;

    strided(aaf_fuzz::reader& in, std::size_t w_, std::size_t h_) : w(w_), h(h_) {
        const std::uint8_t layout = in.byte();
        pixel = sizeof(U) + ((layout & 3u) == 0 ? 0 : (layout >> 2) % 13u);
        row = w * pixel + in.byte() % 9u;
        offset = (layout & 3u) == 3 ? 1 + in.byte() % 7u : 0;  // start away from the allocation's alignment
        bytes.assign(offset + (h == 0 ? 0 : (h - 1) * row + (w == 0 ? 0 : (w - 1) * pixel + sizeof(U))) + 16, sentinel);
    }
    unsigned char* at(std::size_t x, std::size_t y) { return bytes.data() + offset + y * row + x * pixel; }
    void set(std::size_t x, std::size_t y, const U& v) { std::memcpy(at(x, y), &v, sizeof(U)); }
    U get(std::size_t x, std::size_t y) {
        U v;
        std::memcpy(&v, at(x, y), sizeof(U));
        return v;
    }
    aaf::image_view<U> view() { return {reinterpret_cast<U*>(bytes.data() + offset), w, h, pixel, row}; }
    aaf::const_image_view<U> cview() { return view(); }
    /// True when no byte outside the w x h pixels differs from the sentinel.
    bool padding_untouched() const {
        std::vector<bool> inside(bytes.size(), false);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x)
                for (std::size_t b = 0; b < sizeof(U); ++b) inside[offset + y * row + x * pixel + b] = true;
        for (std::size_t i = 0; i < bytes.size(); ++i)
            if (!inside[i] && bytes[i] != sentinel) return false;
        return true;
    }
};

template <class T>
T visibility_value(aaf_fuzz::reader& in, T def) {
    const T v = in.value(def);
    const T cap = static_cast<T>(sizeof(T) == 4 ? 1e30 : 1e300);
    return std::isfinite(v) ? std::clamp(v, -cap, cap) : v;
}

template <class T, class G>
void filter_case(aaf_fuzz::reader& in, std::size_t w, std::size_t h, strided<T>& vis, strided<T>& beta,
                 strided<T>& d, const G& g, const aaf::filter_settings<T>& s, const glm::vec<3, T>& light_normal) {
    strided<T> out(in, w, h), scratch(in, w, h);
    try {
        aaf::filter_visibility<T>(vis.cview(), beta.cview(), d.cview(), out.view(), scratch.view(), g, s, light_normal);
    } catch (const aaf::invalid_argument&) {
        AAF_FUZZ_CHECK(out.padding_untouched());
        for (std::size_t i = 0; i < out.bytes.size(); ++i) AAF_FUZZ_CHECK(out.bytes[i] == sentinel);  // nothing written
        return;
    }
    AAF_FUZZ_CHECK(out.padding_untouched());
    T lo = std::numeric_limits<T>::infinity(), hi = -lo;
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const T v = vis.get(x, y);
            if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
        }
    const T scale = std::max(std::abs(lo), std::abs(hi));
    const T tol = T(256) * std::numeric_limits<T>::epsilon() * (std::isfinite(scale) ? scale : T(0));
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const T v = vis.get(x, y), o = out.get(x, y);
            const bool mean = std::isfinite(o) && o >= lo - tol && o <= hi + tol;
            if (std::isfinite(v)) AAF_FUZZ_CHECK(mean);
            else AAF_FUZZ_CHECK(mean || std::memcmp(&v, &o, sizeof(T)) == 0);
        }
}

template <class T>
void spread_case(aaf_fuzz::reader& in, std::size_t w, std::size_t h, bool with_ids) {
    strided<aaf::slope_pair<T>> slopes(in, w, h), scratch(in, w, h);
    strided<std::uint32_t> ids(in, w, h);
    std::vector<aaf::slope_pair<T>> original(w * h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            aaf::slope_pair<T> p{};
            if (in.flag()) p = {in.value(T(1)), in.value(T(0.5))};
            slopes.set(x, y, p);
            original[y * w + x] = p;
            ids.set(x, y, in.byte() % 3u);
        }
    const std::uint32_t radius = in.count(3);
    try {
        if (with_ids)
            aaf::spread_slopes<T>(slopes.view(), scratch.view(), radius, aaf::guides{aaf::no_guide{}, ids.cview()});
        else
            aaf::spread_slopes<T>(slopes.view(), scratch.view(), radius);
    } catch (const aaf::invalid_argument&) {
        for (std::size_t i = 0; i < original.size(); ++i) {
            const auto got = slopes.get(i % w, i / w);
            AAF_FUZZ_CHECK(std::memcmp(&got, &original[i], sizeof(got)) == 0);
        }
        return;
    }
    AAF_FUZZ_CHECK(slopes.padding_untouched());
    AAF_FUZZ_CHECK(scratch.padding_untouched());
    const auto r = static_cast<std::size_t>(radius);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const aaf::slope_pair<T> got = slopes.get(x, y), own = original[y * w + x];
            if (own.has_occluder() || radius == 0) {
                AAF_FUZZ_CHECK(std::memcmp(&got, &own, sizeof(got)) == 0);
                continue;
            }
            if (!got.has_occluder()) {
                AAF_FUZZ_CHECK(got.s1 == T(0) && got.s2 == std::numeric_limits<T>::infinity());
            }
            if (with_ids) continue;  // the separable rule with IDs is not the square window (documented)
            aaf::slope_pair<T> expect{};
            for (std::size_t yy = y > r ? y - r : 0; yy <= std::min(h - 1, y + r); ++yy)
                for (std::size_t xx = x > r ? x - r : 0; xx <= std::min(w - 1, x + r); ++xx) {
                    const aaf::slope_pair<T> v = original[yy * w + xx];
                    if (!v.has_occluder()) continue;
                    expect.s1 = std::max(expect.s1, v.s1);
                    expect.s2 = std::min(expect.s2, v.s2);
                }
            AAF_FUZZ_CHECK(got.s1 == expect.s1 && got.s2 == expect.s2);  // == : max/min may pick either zero's sign
        }
}

template <class T>
int run(aaf_fuzz::reader& in) {
    using vec3 = glm::vec<3, T>;
    const std::size_t w = 1 + in.byte() % 24u, h = 1 + in.byte() % 24u;
    const std::uint8_t what = in.byte();
    if (what & 0x80u) {
        spread_case<T>(in, w, h, (what & 1u) != 0);
        return 0;
    }
    aaf::filter_settings<T> s;
    s.space = (what & 8u) ? aaf::offset_space::light_plane : aaf::offset_space::image;
    s.truncation = in.value(s.truncation);
    s.max_radius = in.count(s.max_radius);
    s.normal_threshold_degrees = in.value(s.normal_threshold_degrees);
    const vec3 light_normal = in.vec3(vec3(0, 1, 0));

    strided<T> vis(in, w, h), beta(in, w, h), d(in, w, h);
    strided<vec3> normals(in, w, h), positions(in, w, h);
    strided<std::uint32_t> ids(in, w, h);
    const T d0 = T(4) / static_cast<T>(w);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            vis.set(x, y, visibility_value(in, T(0.5)));
            d.set(x, y, in.value(d0));
            beta.set(x, y, in.value(T(1.5) * d0));
            normals.set(x, y, in.vec3(vec3(0, 1, 0)));
            positions.set(x, y, in.vec3(vec3(static_cast<T>(x) * d0, T(0), static_cast<T>(y) * d0)));
            ids.set(x, y, in.byte() % 3u);
        }
    // Every guide combination; positions only matter (and are required) for light-plane offsets.
    const aaf::no_guide none{};
    switch (what & 7u) {
        case 0: filter_case<T>(in, w, h, vis, beta, d, aaf::guides<>{}, s, light_normal); break;
        case 1: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{normals.cview()}, s, light_normal); break;
        case 2: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{none, ids.cview()}, s, light_normal); break;
        case 3: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{normals.cview(), ids.cview()}, s, light_normal); break;
        case 4: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{none, none, positions.cview()}, s, light_normal); break;
        case 5: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{normals.cview(), none, positions.cview()}, s, light_normal); break;
        case 6: filter_case<T>(in, w, h, vis, beta, d, aaf::guides{none, ids.cview(), positions.cview()}, s, light_normal); break;
        default:
            filter_case<T>(in, w, h, vis, beta, d, aaf::guides{normals.cview(), ids.cview(), positions.cview()}, s, light_normal);
            break;
    }
    return 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    return in.flag() ? run<double>(in) : run<float>(in);
}
