// SPDX-License-Identifier: MIT
// libFuzzer harness: the formulas (formulas.hpp) and the statistics they are fed from (occlusion_stats.hpp),
// with arbitrary floats everywhere, in float and double.
//
// Input: formula settings (validated first: invalid ones are rejected, which is not a finding), two records
// built by add_sample from arbitrary sample streams, merged; then slope pairs (from slopes() of the three
// records, and one arbitrary pair) through filter_bandwidth, filter_width, sample_count, target_samples.
//
// Invariants (any violation aborts):
// * records: occluded <= samples; visible_weight <= total_weight; visibility() in [0, 1] when there is light
//   and the weight sum is finite;
// * slopes(): s1 >= s2 >= 0, or the no-occluder identity {0, +inf}; never NaN;
// * for every pair in the formulas' domain (s1 >= s2 >= 0, or a NaN: "no occluder"), σ >= 0 and d >= 0 or NaN:
//   Ω* >= 0, β >= 0, n >= 0, none NaN; target_samples(n, min, max) in [min, max] for min <= max;
//   no occluder gives Ω* = +inf, β = 0, n = 0.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include <aaf/formulas.hpp>
#include <aaf/occlusion_stats.hpp>
#include <aaf/settings.hpp>

#include "fuzz_input.hpp"

namespace {

template <class T>
void check_record(const aaf::occlusion_stats<T>& r) {
    AAF_FUZZ_CHECK(r.occluded <= r.samples);
    AAF_FUZZ_CHECK(!(r.visible_weight > r.total_weight));
    // Weights near the largest T can make their sum overflow; the ratio of two overflowed sums is lost
    // (visibility() is NaN then). aaf's own weights never get there (docs/EXTREMES.md).
    if (!r.has_light()) {
        AAF_FUZZ_CHECK(r.visible_weight == T(0));
    } else if (std::isfinite(r.total_weight)) {
        const T v = r.visibility();
        AAF_FUZZ_CHECK(v >= T(0) && v <= T(1));
    }
}

template <class T>
void check_slopes(const aaf::slope_pair<T>& s) {
    const bool identity = s.s1 == T(0) && s.s2 == std::numeric_limits<T>::infinity();
    AAF_FUZZ_CHECK(identity || (s.s1 >= s.s2 && s.s2 >= T(0)));
}

template <class T>
aaf::occlusion_stats<T> record(aaf_fuzz::reader& in) {
    aaf::occlusion_stats<T> r;
    const std::uint32_t n = in.byte() % 33u;
    for (std::uint32_t i = 0; i < n; ++i) {
        const T weight = in.value(T(1)), d1 = in.value(T(3)), length = in.value(T(3.2));
        aaf::occluder_span<T> hit{};
        switch (in.byte() % 4) {
            case 1: {  // one occluder, as a fraction of the segment
                const T t = length * in.value(T(0.5));
                hit = {t, t};
                break;
            }
            case 2: hit = {in.value(T(1)), in.value(T(2))}; break;  // any two ends
            case 3: hit = {in.value(length), in.value(length)}; break;  // near the light end
            default: break;  // miss
        }
        r.add_sample(weight, d1, length, hit);
        check_record(r);
    }
    return r;
}

template <class T>
bool in_domain(const aaf::slope_pair<T>& s, T sigma, T d) {
    if (std::isnan(s.s1) || std::isnan(s.s2) || std::isnan(sigma) || std::isnan(d)) return true;  // "no occluder"
    return s.s1 >= s.s2 && s.s2 >= T(0) && sigma >= T(0) && d >= T(0);
}

template <class T>
void check_formulas(const aaf::slope_pair<T>& s, T sigma, T d, const aaf::formula_settings<T>& f, std::uint32_t lo,
                    std::uint32_t hi) {
    const T omega = aaf::filter_bandwidth(s, sigma, d, f);
    const T beta = aaf::filter_width(s, sigma, d, f);
    const T n = aaf::sample_count(s, sigma, d, f);
    if (!in_domain(s, sigma, d)) return;  // evaluated (no crash, no UB), but nothing is promised
    AAF_FUZZ_CHECK(omega >= T(0));
    AAF_FUZZ_CHECK(beta >= T(0));
    AAF_FUZZ_CHECK(n >= T(0));
    const bool none = !s.has_occluder() || std::isnan(s.s1) || std::isnan(s.s2) || std::isnan(sigma) || std::isnan(d);
    if (none) {
        AAF_FUZZ_CHECK(omega == std::numeric_limits<T>::infinity());
        AAF_FUZZ_CHECK(beta == T(0));
        AAF_FUZZ_CHECK(n == T(0));
    }
    const std::uint32_t t = aaf::target_samples(n, lo, hi);
    AAF_FUZZ_CHECK(t >= lo && t <= hi);
}

template <class T>
int run(aaf_fuzz::reader& in) {
    aaf::formula_settings<T> f;
    f.form = in.flag() ? aaf::formula_form::authors : aaf::formula_form::paper;
    f.k = in.value(f.k);
    f.mu = in.value(f.mu);
    f.alpha = in.value(f.alpha);
    f.max_slope = in.value(f.max_slope);
    try {
        aaf::validate(f);
    } catch (const aaf::invalid_argument&) {
        return 0;
    }
    std::uint32_t lo = in.count(9), hi = in.count(100);
    if (lo > hi) std::swap(lo, hi);

    const aaf::occlusion_stats<T> a = record<T>(in), b = record<T>(in);
    const aaf::occlusion_stats<T> m = aaf::merge(a, b);
    check_record(m);
    AAF_FUZZ_CHECK(m.samples == a.samples + b.samples);
    const aaf::slope_pair<T> pairs[4] = {aaf::slopes(a, f.max_slope), aaf::slopes(b, f.max_slope),
                                         aaf::slopes(m, f.max_slope), {in.value(T(1)), in.value(T(0.5))}};
    for (int i = 0; i < 3; ++i) check_slopes(pairs[i]);
    // slopes() caps at max_slope (d2 >= d1/(1 + max_slope)), up to rounding and the overflow of 1 + max_slope.
    if (std::isfinite(T(1) + f.max_slope) && aaf::slopes(m, f.max_slope).has_occluder())
        AAF_FUZZ_CHECK(aaf::slopes(m, f.max_slope).s1 <= (f.max_slope + T(1)) * (T(1) + T(16) * std::numeric_limits<T>::epsilon()));

    const T sigma = in.value(T(0.75)), d = in.value(T(0.0625));
    for (const auto& s : pairs) check_formulas(s, sigma, d, f, lo, hi);

    // β from an arbitrary bandwidth: never NaN, never negative.
    const T beta = aaf::filter_width(in.value(T(5)), f.k);
    AAF_FUZZ_CHECK(beta >= T(0));
    return 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    return in.flag() ? run<double>(in) : run<float>(in);
}
