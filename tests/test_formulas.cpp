// SPDX-License-Identifier: MIT
// formulas.hpp and the validation of settings.hpp against the paper (FORMULAS.md §1.2–§1.10, §1.16):
// hand-worked values, a grid against the literal transcription in reference/reference_formulas.hpp,
// the agreement of the paper and authors' forms when light-limited, every documented limit, the
// monotonicity in μ that makes the method consistent, and the error messages of validate().

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <aaf/formulas.hpp>
#include <aaf/occlusion_stats.hpp>
#include <aaf/settings.hpp>

#include "reference/reference_formulas.hpp"

namespace {

template <class T>
constexpr double rel_tol() {
    return sizeof(T) == sizeof(float) ? 1e-5 : 1e-12;
}

bool rel_close(double a, double b, double tol) {
    if (a == b) return true;  // also covers equal infinities
    return std::abs(a - b) <= tol * std::max(std::abs(a), std::abs(b));
}

template <class T>
aaf::formula_settings<T> make_settings(aaf::formula_form form, T k, T mu, T alpha) {
    aaf::formula_settings<T> f;
    f.form = form;
    f.k = k;
    f.mu = mu;
    f.alpha = alpha;
    return f;
}

template <class T>
aaf::slope_pair<T> pair(T s1, T s2) {
    aaf::slope_pair<T> s;
    s.s1 = s1;
    s.s2 = s2;
    return s;
}

constexpr aaf::formula_form both_forms[] = {aaf::formula_form::paper, aaf::formula_form::authors};

const char* name(aaf::formula_form f) { return f == aaf::formula_form::paper ? "paper" : "authors"; }

}  // namespace

// ---------------------------------------------------------------------------------------------------
// (a) Values worked by hand.

TEMPLATE_TEST_CASE("hand-worked values at a light-limited interior point", "[formulas]", float, double) {
    using T = TestType;
    // σ = 0.75, d = 0.03125, s1 = s2 = 0.5, k = 3, μ = 2, α = 1.
    //   light bound 1/(σ s2) = 1/0.375 = 8/3;  pixel bound α/(d(1+s2)) = 1/(0.03125·1.5) = 64/3  → light-limited.
    //   paper Ω* = μ·8/3 = 16/3;  authors Ω* = min(2·8/3, 64/3) = 16/3.
    //   β = 1/(kΩ*) = 1/16 = 0.0625 = σ s2/(kμ) = 0.375/6.
    //   paper n: μ(2/s2)√(d²/(4σ²)) = 2·4·(0.03125/1.5) = 1/6;  α/(1+s2) = 2/3;  1 + μ s1/s2 = 3;
    //            n = 4·3²·(1/6 + 2/3)² = 36·(5/6)² = 25.
    //   authors n: α/(1+s2) + dΩ* = 2/3 + 0.03125·16/3 = 5/6;
    //              σ·min(s1Ω*, s1/(d(1+s1))) = 0.75·min(8/3, 32/3) = 2;  n = 4·(5/6)²·3² = 25.
    const T sigma = T(0.75), d = T(0.03125);
    const auto s = pair<T>(T(0.5), T(0.5));
    for (auto form : both_forms) {
        INFO(name(form));
        const auto f = make_settings<T>(form, T(3), T(2), T(1));
        CHECK(aaf::filter_bandwidth(s, sigma, d, f) == Approx(16.0 / 3.0).epsilon(rel_tol<T>()));
        CHECK(aaf::filter_width(s, sigma, d, f) == Approx(0.0625).epsilon(rel_tol<T>()));
        CHECK(aaf::sample_count(s, sigma, d, f) == Approx(25.0).epsilon(rel_tol<T>()));
    }
    CHECK(aaf::light_bandwidth(sigma) == Approx(4.0 / 3.0).epsilon(rel_tol<T>()));
    CHECK(aaf::pixel_bandwidth(d) == Approx(32.0).epsilon(rel_tol<T>()));
    CHECK(aaf::light_limited_bandwidth(sigma, T(0.5)) == Approx(8.0 / 3.0).epsilon(rel_tol<T>()));
    CHECK(aaf::receiver_bandlimit(d, T(0.5), T(1)) == Approx(64.0 / 3.0).epsilon(rel_tol<T>()));
}

TEMPLATE_TEST_CASE("hand-worked values at a pixel-limited interior point", "[formulas]", float, double) {
    using T = TestType;
    // σ = 1, d = 0.25, s1 = 1, s2 = 0.25, k = 3, μ = 2, α = 1.
    //   light bound 1/(σ s2) = 4;  pixel bound α/(d(1+s2)) = 1/(0.25·1.25) = 3.2  → pixel-limited.
    //   paper Ω* = μ·3.2 = 6.4, β = 1/19.2;   authors Ω* = min(8, 3.2) = 3.2, β = 1/9.6.
    //   paper n: μ(2/s2)√(d²/(4σ²)) = 2·8·0.125 = 2;  α/(1+s2) = 0.8;  1 + μ s1/s2 = 9;
    //            n = 4·81·(2.8)² = 2540.16.
    //   authors n: α/(1+s2) + dΩ* = 0.8 + 0.25·3.2 = 1.6;  σ·min(s1Ω*, s1/(d(1+s1))) = min(3.2, 2) = 2;
    //              n = 4·1.6²·3² = 92.16.
    const T sigma = T(1), d = T(0.25);
    const auto s = pair<T>(T(1), T(0.25));
    const auto paper = make_settings<T>(aaf::formula_form::paper, T(3), T(2), T(1));
    const auto authors = make_settings<T>(aaf::formula_form::authors, T(3), T(2), T(1));
    CHECK(aaf::filter_bandwidth(s, sigma, d, paper) == Approx(6.4).epsilon(rel_tol<T>()));
    CHECK(aaf::filter_width(s, sigma, d, paper) == Approx(1.0 / 19.2).epsilon(rel_tol<T>()));
    CHECK(aaf::sample_count(s, sigma, d, paper) == Approx(2540.16).epsilon(rel_tol<T>()));
    CHECK(aaf::filter_bandwidth(s, sigma, d, authors) == Approx(3.2).epsilon(rel_tol<T>()));
    CHECK(aaf::filter_width(s, sigma, d, authors) == Approx(1.0 / 9.6).epsilon(rel_tol<T>()));
    CHECK(aaf::sample_count(s, sigma, d, authors) == Approx(92.16).epsilon(rel_tol<T>()));
}

TEMPLATE_TEST_CASE("slopes from distances and the pinhole pixel size", "[formulas]", float, double) {
    using T = TestType;
    // d1 = 4, d2min = 1, d2max = 3: s1 = 4/1 − 1 = 3, s2 = 4/3 − 1 = 1/3 (FORMULAS.md §1.2).
    aaf::occlusion_stats<T> st;
    st.d1 = T(4);
    st.d2min = T(1);
    st.d2max = T(3);
    st.occluded = 1;
    st.samples = 1;
    st.total_weight = T(1);
    const auto s = aaf::slopes(st);
    CHECK(s.s1 == Approx(aaf_ref::slope_s1(4, 1)).epsilon(rel_tol<T>()));
    CHECK(s.s2 == Approx(aaf_ref::slope_s2(4, 3)).epsilon(rel_tol<T>()));
    CHECK(s.s1 == Approx(3.0).epsilon(rel_tol<T>()));
    CHECK(s.s2 == Approx(1.0 / 3.0).epsilon(rel_tol<T>()));
    // §1.5: d = (2/H)·t·tan(fov/2); the authors' 720p/60° case is (1/360)·t·tan 30°.
    const T t = T(10), tan30 = static_cast<T>(std::tan(3.14159265358979323846 / 6.0));
    CHECK(aaf::pinhole_pixel_size(t, tan30, 720u) == Approx(10.0 * std::tan(3.14159265358979323846 / 6.0) / 360.0).epsilon(rel_tol<T>()));
    CHECK(aaf::pinhole_pixel_size(t, tan30, 0u) == T(0));
}

// ---------------------------------------------------------------------------------------------------
// (b) Library vs the literal transcription, over a grid of interior points.

TEMPLATE_TEST_CASE("formulas match the paper's literal equations over an interior grid", "[formulas]", float, double) {
    using T = TestType;
    const double tol = rel_tol<T>();
    const double sigmas[] = {0.01, 0.1, 0.75, 3.0, 40.0};
    const double ds[] = {1e-4, 0.003, 0.03125, 0.5, 2.0};
    const double s2s[] = {1e-3, 0.05, 0.5, 2.0, 30.0};
    const double ratios[] = {1.0, 1.5, 10.0, 1000.0};
    const double mus[] = {1.0, 2.0, 4.5};
    const double alphas[] = {0.5, 1.0, 2.0};
    const double ks[] = {1.0, 3.0, 6.0};
    // Inputs are rounded to T first; the reference then sees exactly the values the library sees.
    const auto r = [](double v) { return static_cast<double>(static_cast<T>(v)); };
    std::size_t checked = 0, mismatches = 0;
    for (double sigma_ : sigmas)
        for (double d_ : ds)
            for (double s2_ : s2s)
                for (double ratio : ratios)
                    for (double mu_ : mus)
                        for (double alpha_ : alphas)
                            for (double k_ : ks) {
                                const double sigma = r(sigma_), d = r(d_), s2 = r(s2_), s1 = r(s2_ * ratio);
                                const double mu = r(mu_), alpha = r(alpha_), k = r(k_);
                                const auto s = pair<T>(static_cast<T>(s1), static_cast<T>(s2));
                                for (auto form : both_forms) {
                                    const auto f = make_settings<T>(form, static_cast<T>(k), static_cast<T>(mu), static_cast<T>(alpha));
                                    const bool paper = form == aaf::formula_form::paper;
                                    const double omega_ref = paper ? aaf_ref::omega_paper(sigma, d, s2, mu, alpha)
                                                                   : aaf_ref::omega_authors(sigma, d, s2, mu, alpha);
                                    const double beta_ref = aaf_ref::beta(omega_ref, k);
                                    const double n_ref = paper ? aaf_ref::n_paper(sigma, d, s1, s2, mu, alpha)
                                                               : aaf_ref::n_authors(sigma, d, s1, s2, mu, alpha);
                                    const T sg = static_cast<T>(sigma), dd = static_cast<T>(d);
                                    const double omega = static_cast<double>(aaf::filter_bandwidth(s, sg, dd, f));
                                    const double beta = static_cast<double>(aaf::filter_width(s, sg, dd, f));
                                    const double beta2 = static_cast<double>(aaf::filter_width(static_cast<T>(omega), f.k));
                                    const double n = static_cast<double>(aaf::sample_count(s, sg, dd, f));
                                    const bool ok = rel_close(omega, omega_ref, tol) && rel_close(beta, beta_ref, tol) &&
                                                    rel_close(beta2, beta_ref, tol) && rel_close(n, n_ref, tol);
                                    ++checked;
                                    if (!ok) {
                                        ++mismatches;
                                        if (mismatches <= 5) {
                                            INFO(name(form) << " sigma=" << sigma << " d=" << d << " s1=" << s1 << " s2=" << s2
                                                            << " mu=" << mu << " alpha=" << alpha << " k=" << k);
                                            CHECK(omega == Approx(omega_ref).epsilon(tol));
                                            CHECK(beta == Approx(beta_ref).epsilon(tol));
                                            CHECK(n == Approx(n_ref).epsilon(tol));
                                        }
                                    }
                                }
                            }
    CHECK(checked == 2u * 5 * 5 * 5 * 4 * 3 * 3 * 3);
    CHECK(mismatches == 0u);
}

TEMPLATE_TEST_CASE("bandwidth helpers match the paper", "[formulas]", float, double) {
    using T = TestType;
    const double tol = rel_tol<T>();
    for (double sigma : {0.01, 0.5, 7.0})
        for (double d : {1e-3, 0.25, 3.0})
            for (double s2 : {1e-3, 0.5, 20.0})
                for (double alpha : {0.5, 1.0, 2.0}) {
                    const T sg = static_cast<T>(sigma), dd = static_cast<T>(d), ss = static_cast<T>(s2), aa = static_cast<T>(alpha);
                    const double rs = static_cast<double>(sg), rd = static_cast<double>(dd), rs2 = static_cast<double>(ss),
                                 ra = static_cast<double>(aa);
                    CHECK(rel_close(static_cast<double>(aaf::light_bandwidth(sg)), aaf_ref::light_bandwidth(rs), tol));
                    CHECK(rel_close(static_cast<double>(aaf::pixel_bandwidth(dd)), aaf_ref::pixel_bandwidth(rd), tol));
                    CHECK(rel_close(static_cast<double>(aaf::receiver_bandlimit(dd, ss, aa)), aaf_ref::receiver_bandlimit(rd, rs2, ra), tol));
                    CHECK(rel_close(static_cast<double>(aaf::light_limited_bandwidth(sg, ss)), aaf_ref::light_bandwidth(rs) / rs2, tol));
                }
}

TEST_CASE("the reference's beta equals the paper crop's max form", "[formulas]") {
    // Self-check of the oracle: β = 1/(kΩ*) with the paper's Ω* is the crop's (1/k)(1/μ)max[σ s2, 1/Ω_x^max].
    for (double sigma : {0.05, 0.75, 4.0})
        for (double d : {1e-3, 0.03125, 0.5})
            for (double s2 : {0.01, 0.5, 9.0})
                for (double mu : {1.0, 2.0, 3.5}) {
                    const double b1 = aaf_ref::beta(aaf_ref::omega_paper(sigma, d, s2, mu, 1.0), 3.0);
                    const double b2 = aaf_ref::beta_paper_crop(sigma, d, s2, 3.0, mu, 1.0);
                    CHECK(b1 == Approx(b2).epsilon(1e-13));
                }
}

// ---------------------------------------------------------------------------------------------------
// (c) Paper and authors' forms agree when light-limited.

TEMPLATE_TEST_CASE("paper and authors' forms agree when light-limited", "[formulas]", float, double) {
    using T = TestType;
    const double tol = rel_tol<T>();
    std::size_t omega_cases = 0, n_cases = 0;
    for (double sigma : {0.05, 0.3, 1.0, 5.0})
        for (double d : {1e-4, 1e-3, 0.01, 0.1})
            for (double s2 : {0.1, 0.7, 3.0, 25.0})
                for (double ratio : {1.0, 1.3, 4.0, 50.0})
                    for (double mu : {1.0, 2.0, 3.0})
                        for (double alpha : {0.5, 1.0, 2.0}) {
                            const T sg = static_cast<T>(sigma), dd = static_cast<T>(d);
                            const auto s = pair<T>(static_cast<T>(s2 * ratio), static_cast<T>(s2));
                            const double s1 = static_cast<double>(s.s1);
                            const auto fp = make_settings<T>(aaf::formula_form::paper, T(3), static_cast<T>(mu), static_cast<T>(alpha));
                            auto fa = fp;
                            fa.form = aaf::formula_form::authors;
                            const double light = mu / (sigma * s2);
                            // Ω*: both are μ/(σ s2) once the μ-scaled light bound is below the pixel bound (§1.7).
                            if (light < 0.999 * alpha / (d * (1 + s2))) {
                                ++omega_cases;
                                CHECK(rel_close(static_cast<double>(aaf::filter_bandwidth(s, sg, dd, fp)),
                                                static_cast<double>(aaf::filter_bandwidth(s, sg, dd, fa)), tol));
                                CHECK(rel_close(static_cast<double>(aaf::filter_width(s, sg, dd, fp)),
                                                static_cast<double>(aaf::filter_width(s, sg, dd, fa)), tol));
                                // n: the authors' form reduces to the paper's when Ω* = μ/(σ s2) and the wedge cap
                                // s1/(d(1+s1)) is inactive (§1.9).
                                if (light < 0.999 / (d * (1 + s1))) {
                                    ++n_cases;
                                    CHECK(rel_close(static_cast<double>(aaf::sample_count(s, sg, dd, fp)),
                                                    static_cast<double>(aaf::sample_count(s, sg, dd, fa)), tol));
                                }
                            }
                        }
    CHECK(omega_cases > 500u);
    CHECK(n_cases > 300u);
}

// ---------------------------------------------------------------------------------------------------
// (d) Limits (formulas.hpp header comment and FORMULAS.md §1.16).

TEMPLATE_TEST_CASE("limit: no occluder", "[formulas][limits]", float, double) {
    using T = TestType;
    const aaf::slope_pair<T> none{};
    CHECK_FALSE(none.has_occluder());
    for (auto form : both_forms) {
        INFO(name(form));
        const auto f = make_settings<T>(form, T(3), T(2), T(1));
        for (T sigma : {T(0), T(0.5)})
            for (T d : {T(0), T(0.01)}) {
                CHECK(aaf::filter_bandwidth(none, sigma, d, f) == std::numeric_limits<T>::infinity());
                CHECK(aaf::filter_width(none, sigma, d, f) == T(0));
                CHECK(aaf::sample_count(none, sigma, d, f) == T(0));
            }
    }
    // The stats route: only unoccluded samples → no slopes.
    aaf::occlusion_stats<T> st;
    st.add_sample(T(1), T(2), T(2.5), aaf::occluder_span<T>{});
    const auto s = aaf::slopes(st);
    CHECK(s.s1 == T(0));
    CHECK(s.s2 == std::numeric_limits<T>::infinity());
    CHECK(aaf::filter_width(T(std::numeric_limits<T>::infinity()), T(3)) == T(0));
}

TEMPLATE_TEST_CASE("limit: contact shadow, s2 -> 0", "[formulas][limits]", float, double) {
    using T = TestType;
    const T sigma = T(0.5), d = T(0.02), k = T(3), mu = T(2), alpha = T(1.5);
    const auto fp = make_settings<T>(aaf::formula_form::paper, k, mu, alpha);
    const auto fa = make_settings<T>(aaf::formula_form::authors, k, mu, alpha);
    for (T s1 : {T(0), T(0.4), T(7)}) {
        INFO("s1 = " << s1);
        const auto s = pair<T>(s1, T(0));
        // Light bound +∞ → pixel-limited Ω*: paper μα/d, authors α/d (the pixel bound at s2 = 0).
        CHECK(aaf::filter_bandwidth(s, sigma, d, fp) == Approx(mu * alpha / d).epsilon(rel_tol<T>()));
        CHECK(aaf::filter_bandwidth(s, sigma, d, fa) == Approx(alpha / d).epsilon(rel_tol<T>()));
        // β ≈ d/(kμα) (paper), d/(kα) (authors): a near no-op filter, finite and > 0.
        CHECK(aaf::filter_width(s, sigma, d, fp) == Approx(d / (k * mu * alpha)).epsilon(rel_tol<T>()));
        CHECK(aaf::filter_width(s, sigma, d, fa) == Approx(d / (k * alpha)).epsilon(rel_tol<T>()));
        // Paper n diverges (callers clamp); authors' n is finite and is the limit of the literal formula.
        CHECK(aaf::sample_count(s, sigma, d, fp) == std::numeric_limits<T>::infinity());
        CHECK(aaf::target_samples(aaf::sample_count(s, sigma, d, fp), 9u, 100u) == 100u);
        const T na = aaf::sample_count(s, sigma, d, fa);
        REQUIRE(std::isfinite(na));
        // Along s1 = s2 = s → 0 the limit is 16α²; for fixed s1 > 0 and s2 → 0⁺ it is the formula at s2 = 1e-12.
        const double limit = s1 == T(0) ? 16.0 * static_cast<double>(alpha) * static_cast<double>(alpha)
                                        : aaf_ref::n_authors(static_cast<double>(sigma), static_cast<double>(d),
                                                             static_cast<double>(s1), 1e-12, static_cast<double>(mu),
                                                             static_cast<double>(alpha));
        CHECK(static_cast<double>(na) == Approx(limit).epsilon(1e-5));
        if (s1 == T(0))
            CHECK(aaf_ref::n_authors(static_cast<double>(sigma), static_cast<double>(d), 1e-12, 1e-12,
                                     static_cast<double>(mu), static_cast<double>(alpha)) == Approx(limit).epsilon(1e-6));
    }
    // Approaching the limit: the paper's n grows without bound, β tends to its contact value.
    T previous = 0;
    for (T s2 : {T(1e-1), T(1e-2), T(1e-3), T(1e-4), T(1e-5)}) {
        const auto s = pair<T>(T(0.4), s2);
        const T n = aaf::sample_count(s, sigma, d, fp);
        CHECK(std::isfinite(n));
        CHECK(n > previous);
        previous = n;
    }
    CHECK(aaf::filter_width(pair<T>(T(0.4), T(1e-6)), sigma, d, fp) == Approx(d / (k * mu * alpha)).epsilon(1e-5));
}

TEMPLATE_TEST_CASE("limit: occluder at the light, d2 -> 0, is capped by slopes()", "[formulas][limits]", float, double) {
    using T = TestType;
    for (T max_slope : {T(100), T(1e6)}) {
        INFO("max_slope = " << max_slope);
        aaf::occlusion_stats<T> st;
        // Both hits at the light end of the segment: d2min = d2max = 0.
        st.add_sample(T(1), T(2), T(4), aaf::occluder_span<T>{T(4), T(4)});
        REQUIRE(st.d2min == T(0));
        REQUIRE(st.d2max == T(0));
        const auto s = aaf::slopes(st, max_slope);
        CHECK(std::isfinite(s.s1));
        CHECK(std::isfinite(s.s2));
        CHECK(s.s1 == Approx(max_slope).epsilon(rel_tol<T>() * 10));
        CHECK(s.s2 == Approx(max_slope).epsilon(rel_tol<T>() * 10));
        for (auto form : both_forms) {
            INFO(name(form));
            const auto f = make_settings<T>(form, T(3), T(2), T(1));
            const T omega = aaf::filter_bandwidth(s, T(0.5), T(0.01), f);
            CHECK(std::isfinite(omega));
            CHECK(omega > T(0));
            const T beta = aaf::filter_width(s, T(0.5), T(0.01), f);
            CHECK(std::isfinite(beta));
            CHECK(beta > T(0));
            const T n = aaf::sample_count(s, T(0.5), T(0.01), f);
            CHECK(std::isfinite(n));
            CHECK(n >= T(0));
        }
        // One hit at the light and one in the middle: s1 capped, s2 = d1/(d1/2) − 1 = 1.
        aaf::occlusion_stats<T> mixed;
        mixed.add_sample(T(1), T(2), T(4), aaf::occluder_span<T>{T(2), T(4)});
        const auto m = aaf::slopes(mixed, max_slope);
        CHECK(m.s1 == Approx(max_slope).epsilon(rel_tol<T>() * 10));
        CHECK(m.s2 == Approx(1.0).epsilon(rel_tol<T>()));
        const auto f = make_settings<T>(aaf::formula_form::paper, T(3), T(2), T(1));
        CHECK(std::isfinite(aaf::sample_count(m, T(0.5), T(0.01), f)));
    }
}

TEMPLATE_TEST_CASE("limit: d2 > d1 from noise is a contact", "[formulas][limits]", float, double) {
    using T = TestType;
    aaf::occlusion_stats<T> st;
    st.samples = st.occluded = 1;
    st.total_weight = T(1);
    st.d1 = T(2);
    st.d2max = T(2.5);  // beyond the receiver
    st.d2min = T(1);
    auto s = aaf::slopes(st);
    CHECK(s.s2 == T(0));
    CHECK(s.s1 == Approx(1.0).epsilon(rel_tol<T>()));
    st.d2min = T(2.25);  // both beyond
    s = aaf::slopes(st);
    CHECK(s.s1 == T(0));
    CHECK(s.s2 == T(0));
    for (auto form : both_forms) {
        const auto f = make_settings<T>(form, T(3), T(2), T(1));
        CHECK(std::isfinite(aaf::filter_width(s, T(0.5), T(0.01), f)));
        CHECK(aaf::filter_width(s, T(0.5), T(0.01), f) > T(0));
    }
}

TEMPLATE_TEST_CASE("limit: point light, sigma = 0", "[formulas][limits]", float, double) {
    using T = TestType;
    const T d = T(0.02), k = T(3), mu = T(2), alpha = T(1);
    for (auto form : both_forms) {
        INFO(name(form));
        const auto f = make_settings<T>(form, k, mu, alpha);
        for (T s2 : {T(0), T(0.3), T(4)}) {
            const auto s = pair<T>(s2 * T(2), s2);
            // One sample is exact for a point light.
            CHECK(aaf::sample_count(s, T(0), d, f) == T(1));
            // Ω* is pixel-limited: the light bound 1/(σ s2) is +∞.
            const T expected = (form == aaf::formula_form::paper ? mu : T(1)) * alpha / (d * (T(1) + s2));
            CHECK(aaf::filter_bandwidth(s, T(0), d, f) == Approx(expected).epsilon(rel_tol<T>()));
            const T beta = aaf::filter_width(s, T(0), d, f);
            CHECK(std::isfinite(beta));
            CHECK(beta > T(0));
            if (s2 > T(0)) {
                // ... and it is the σ → 0⁺ limit of the literal Ω*.
                const double lim = form == aaf::formula_form::paper
                                       ? aaf_ref::omega_paper(1e-12, static_cast<double>(d), static_cast<double>(s2), 2, 1)
                                       : aaf_ref::omega_authors(1e-12, static_cast<double>(d), static_cast<double>(s2), 2, 1);
                CHECK(static_cast<double>(aaf::filter_bandwidth(s, T(0), d, f)) == Approx(lim).epsilon(rel_tol<T>()));
            }
        }
    }
}

TEMPLATE_TEST_CASE("limit: zero pixel size, d = 0", "[formulas][limits]", float, double) {
    using T = TestType;
    const T sigma = T(0.6), k = T(3), mu = T(2.5), alpha = T(1.25);
    for (auto form : both_forms) {
        INFO(name(form));
        const auto f = make_settings<T>(form, k, mu, alpha);
        for (T s2 : {T(0.05), T(0.5), T(6)})
            for (T ratio : {T(1), T(3)}) {
                const auto s = pair<T>(s2 * ratio, s2);
                // Pixel bound +∞: Ω* light-limited, μ/(σ s2) in both forms.
                CHECK(aaf::filter_bandwidth(s, sigma, T(0), f) == Approx(mu / (sigma * s2)).epsilon(rel_tol<T>()));
                CHECK(aaf::filter_width(s, sigma, T(0), f) == Approx(sigma * s2 / (k * mu)).epsilon(rel_tol<T>()));
                // n: d·Ω* → 0, leaving 4(1 + μ s1/s2)²(α/(1+s2))²: the d → 0⁺ limit of the literal formula.
                const T n = aaf::sample_count(s, sigma, T(0), f);
                const double a = 1 + static_cast<double>(mu) * static_cast<double>(s.s1) / static_cast<double>(s2);
                const double b = static_cast<double>(alpha) / (1 + static_cast<double>(s2));
                CHECK(static_cast<double>(n) == Approx(4 * a * a * b * b).epsilon(rel_tol<T>()));
                const double lim = form == aaf::formula_form::paper
                                       ? aaf_ref::n_paper(0.6, 1e-13, static_cast<double>(s.s1), static_cast<double>(s2), 2.5, 1.25)
                                       : aaf_ref::n_authors(0.6, 1e-13, static_cast<double>(s.s1), static_cast<double>(s2), 2.5, 1.25);
                CHECK(static_cast<double>(n) == Approx(lim).epsilon(1e-5));
            }
        // d = 0 at a contact: both bounds are +∞, so Ω* = +∞ and β = 0 (unfiltered).
        const auto contact = pair<T>(T(0.5), T(0));
        CHECK(aaf::filter_bandwidth(contact, sigma, T(0), f) == std::numeric_limits<T>::infinity());
        CHECK(aaf::filter_width(contact, sigma, T(0), f) == T(0));
        // ... and n = +∞ (the limit of both forms in either order), which target_samples clamps.
        CHECK(aaf::sample_count(contact, sigma, T(0), f) == std::numeric_limits<T>::infinity());
        CHECK(aaf::target_samples(aaf::sample_count(contact, sigma, T(0), f), 9u, 64u) == 64u);
        // d = 0 and σ = 0: nothing bounds Ω*; a point light needs one sample.
        CHECK(aaf::filter_width(pair<T>(T(1), T(0.5)), T(0), T(0), f) == T(0));
        CHECK(aaf::sample_count(pair<T>(T(1), T(0.5)), T(0), T(0), f) == T(1));
    }
}

TEMPLATE_TEST_CASE("limit: NaN inputs are treated as no occluder", "[formulas][limits]", float, double) {
    using T = TestType;
    const T nan = std::numeric_limits<T>::quiet_NaN();
    const T inf = std::numeric_limits<T>::infinity();
    for (auto form : both_forms) {
        INFO(name(form));
        const auto f = make_settings<T>(form, T(3), T(2), T(1));
        struct input {
            aaf::slope_pair<T> s;
            T sigma, d;
            const char* what;
        };
        const input inputs[] = {
            {pair<T>(nan, T(0.5)), T(0.5), T(0.01), "s1 = NaN"},
            {pair<T>(T(1), nan), T(0.5), T(0.01), "s2 = NaN"},
            {pair<T>(nan, nan), T(0.5), T(0.01), "s1 = s2 = NaN"},
            {pair<T>(T(1), T(0.5)), nan, T(0.01), "sigma = NaN"},
            {pair<T>(T(1), T(0.5)), T(0.5), nan, "d = NaN"},
            {pair<T>(T(1), T(0)), nan, T(0.01), "sigma = NaN at contact"},
            {pair<T>(T(1), T(0)), T(0.5), nan, "d = NaN at contact"},
        };
        for (const input& in : inputs) {
            INFO(in.what);
            CHECK(aaf::filter_bandwidth(in.s, in.sigma, in.d, f) == inf);
            CHECK(aaf::filter_width(in.s, in.sigma, in.d, f) == T(0));
            CHECK(aaf::sample_count(in.s, in.sigma, in.d, f) == T(0));
        }
        // β from a NaN bandwidth is "do not filter", never an infinite blur.
        CHECK(aaf::filter_width(nan, T(3)) == T(0));
        // NaN distances in a record (corrupted): like every NaN input, "no occluder" — the {0, +inf}
        // identity, which neither filters nor spreads, rather than an invented contact shadow.
        aaf::occlusion_stats<T> st;
        st.samples = st.occluded = 1;
        st.total_weight = T(1);
        st.d1 = T(2);
        st.d2min = nan;
        st.d2max = nan;
        const auto s = aaf::slopes(st);
        CHECK_FALSE(s.has_occluder());
        CHECK(s.s1 == T(0));
        CHECK(s.s2 == inf);
        st.d2min = T(1);  // one NaN end is enough
        CHECK_FALSE(aaf::slopes(st).has_occluder());
        st.d2max = T(1);
        CHECK(aaf::slopes(st).has_occluder());
        st.d1 = nan;
        CHECK_FALSE(aaf::slopes(st).has_occluder());
    }
}

namespace {

/// The exact n (double precision) away from the documented infinities: the literal formula for d > 0,
/// s2 > 0; its d → 0⁺ limit; and the authors' form at s2 = 0 with d > 0.
template <class T>
double true_n(aaf::formula_form form, T sigma_, T d_, T s1_, T s2_, T mu_, T alpha_) {
    const double sigma = static_cast<double>(sigma_), d = static_cast<double>(d_), s1 = static_cast<double>(s1_),
                 s2 = static_cast<double>(s2_), mu = static_cast<double>(mu_), alpha = static_cast<double>(alpha_);
    const bool paper = form == aaf::formula_form::paper;
    if (d > 0 && s2 > 0) return paper ? aaf_ref::n_paper(sigma, d, s1, s2, mu, alpha) : aaf_ref::n_authors(sigma, d, s1, s2, mu, alpha);
    if (d == 0 && s2 > 0) {
        const double a = 1 + mu * s1 / s2, b = alpha / (1 + s2);
        return 4 * a * a * b * b;
    }
    if (!paper && d > 0 && s2 == 0) {
        const double b = 1 + sigma * std::min(s1 * alpha / d, s1 / (d * (1 + s1)));
        return 16 * alpha * alpha * b * b;
    }
    return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

TEMPLATE_TEST_CASE("limits sweep: results are finite or exactly as documented", "[formulas][limits]", float, double) {
    using T = TestType;
    const T inf = std::numeric_limits<T>::infinity();
    const T nan = std::numeric_limits<T>::quiet_NaN();
    const T values[] = {T(0), T(1e-30), T(1e-6), T(0.3), T(2), T(1e6)};
    std::vector<aaf::slope_pair<T>> pairs;
    for (T s2 : values)
        for (T s1 : values)
            if (s1 >= s2) pairs.push_back(pair<T>(s1, s2));
    pairs.push_back(aaf::slope_pair<T>{});
    pairs.push_back(pair<T>(nan, T(1)));
    const T sigmas[] = {T(0), T(1e-20), T(0.5), T(1e4), nan};
    const T ds[] = {T(0), T(1e-20), T(0.01), T(1e3), nan};
    for (auto form : both_forms)
        for (T mu : {T(1), T(2), T(100)})
            for (const auto& s : pairs)
                for (T sigma : sigmas)
                    for (T d : ds) {
                        const auto f = make_settings<T>(form, T(3), mu, T(1));
                        INFO(name(form) << " mu=" << mu << " s1=" << s.s1 << " s2=" << s.s2 << " sigma=" << sigma << " d=" << d);
                        const bool none = !s.has_occluder() || std::isnan(s.s1) || std::isnan(sigma) || std::isnan(d);
                        const T omega = aaf::filter_bandwidth(s, sigma, d, f);
                        const T beta = aaf::filter_width(s, sigma, d, f);
                        const T n = aaf::sample_count(s, sigma, d, f);
                        CHECK_FALSE(std::isnan(omega));
                        CHECK_FALSE(std::isnan(n));
                        CHECK(omega >= T(0));
                        CHECK(n >= T(0));
                        CHECK(beta >= T(0));
                        CHECK(std::isfinite(beta));
                        if (none) {
                            CHECK(omega == inf);
                            CHECK(beta == T(0));
                            CHECK(n == T(0));
                            continue;
                        }
                        // Ω* = +∞ only when both bounds are +∞ (σ s2 = 0 and d = 0, up to underflow of the products).
                        if (omega == inf) {
                            CHECK(aaf::light_limited_bandwidth(sigma, s.s2) == inf);
                            CHECK(aaf::receiver_bandlimit(d, s.s2, T(1)) == inf);
                        }
                        if (sigma == T(0)) CHECK(n == T(1));
                        // n = +∞ only at a contact (paper form with s2 = 0, or either form with s2 = 0 and d = 0),
                        // or where the true value does not fit in T.
                        if (n == inf && !(s.s2 == T(0) && (form == aaf::formula_form::paper || d == T(0))))
                            CHECK(true_n(form, sigma, d, s.s1, s.s2, mu, T(1)) > 0.5 * static_cast<double>(std::numeric_limits<T>::max()));
                        const std::uint32_t t = aaf::target_samples(n, 9u, 100u);
                        CHECK(t >= 9u);
                        CHECK(t <= 100u);
                    }
}

TEMPLATE_TEST_CASE("target_samples rounds up and clamps", "[formulas][limits]", float, double) {
    using T = TestType;
    const T inf = std::numeric_limits<T>::infinity();
    CHECK(aaf::target_samples(std::numeric_limits<T>::quiet_NaN(), 9u, 100u) == 9u);
    CHECK(aaf::target_samples(inf, 9u, 100u) == 100u);
    CHECK(aaf::target_samples(-inf, 9u, 100u) == 9u);
    CHECK(aaf::target_samples(T(-5), 9u, 100u) == 9u);
    CHECK(aaf::target_samples(T(0), 9u, 100u) == 9u);
    CHECK(aaf::target_samples(T(9), 9u, 100u) == 9u);
    CHECK(aaf::target_samples(T(9.01), 9u, 100u) == 10u);
    CHECK(aaf::target_samples(T(56), 9u, 100u) == 56u);
    CHECK(aaf::target_samples(T(55.2), 9u, 100u) == 56u);
    CHECK(aaf::target_samples(T(99.5), 9u, 100u) == 100u);
    CHECK(aaf::target_samples(T(100), 9u, 100u) == 100u);
    CHECK(aaf::target_samples(T(1e30), 9u, 100u) == 100u);
    CHECK(aaf::target_samples(T(3e9), 1u, 4000000000u) == 3000000000u);
    CHECK(aaf::target_samples(T(25), 25u, 25u) == 25u);
    CHECK(aaf::target_samples(T(0.5), 0u, 10u) == 1u);
}

// ---------------------------------------------------------------------------------------------------
// (e) Monotonicity in μ: the consistency mechanism (§1.10).

TEMPLATE_TEST_CASE("raising mu narrows the filter and raises the sample count", "[formulas][consistency]", float, double) {
    using T = TestType;
    const T mus[] = {T(1), T(1.5), T(2), T(3), T(5), T(10), T(100)};
    for (T sigma : {T(0.1), T(0.75), T(3)})
        for (T d : {T(0.001), T(0.03), T(0.3)})
            for (T s2 : {T(0.05), T(0.5), T(4)})
                for (T ratio : {T(1), T(5)}) {
                    const auto s = pair<T>(s2 * ratio, s2);
                    INFO("sigma=" << sigma << " d=" << d << " s2=" << s2 << " s1=" << s.s1);
                    T beta_p = std::numeric_limits<T>::infinity(), beta_a = beta_p, n_p = 0, n_a = 0;
                    for (T mu : mus) {
                        const auto fp = make_settings<T>(aaf::formula_form::paper, T(3), mu, T(1));
                        const auto fa = make_settings<T>(aaf::formula_form::authors, T(3), mu, T(1));
                        const T bp = aaf::filter_width(s, sigma, d, fp), ba = aaf::filter_width(s, sigma, d, fa);
                        const T np = aaf::sample_count(s, sigma, d, fp), na = aaf::sample_count(s, sigma, d, fa);
                        CHECK(bp < beta_p);  // paper: β ∝ 1/μ, strictly
                        CHECK(ba <= beta_a);
                        CHECK(np > n_p);  // paper: n strictly increasing in μ
                        CHECK(na >= n_a);
                        // β(μ) = β(1)/μ exactly in the paper form.
                        const auto f1 = make_settings<T>(aaf::formula_form::paper, T(3), T(1), T(1));
                        CHECK(bp == Approx(aaf::filter_width(s, sigma, d, f1) / mu).epsilon(rel_tol<T>() * 4));
                        beta_p = bp, beta_a = ba, n_p = np, n_a = na;
                    }
                    // As μ grows, β → 0 and n → ∞ (pure Monte Carlo in the limit).
                    CHECK(beta_p < aaf::filter_width(s, sigma, d, make_settings<T>(aaf::formula_form::paper, T(3), T(1), T(1))) / T(50));
                }
}

// ---------------------------------------------------------------------------------------------------
// (f) validate() names the field.

namespace {

template <class F>
std::string what_of(F&& f) {
    try {
        f();
    } catch (const aaf::invalid_argument& e) {
        return e.what();
    } catch (...) {
        return "<wrong exception type>";
    }
    return "<no exception>";
}

bool contains(const std::string& s, const std::string& needle) { return s.find(needle) != std::string::npos; }

}  // namespace

TEMPLATE_TEST_CASE("validate() rejects invalid formula and filter settings, naming the field", "[formulas][settings]", float, double) {
    using T = TestType;
    const T nan = std::numeric_limits<T>::quiet_NaN();
    const T inf = std::numeric_limits<T>::infinity();
    CHECK_NOTHROW(aaf::validate(aaf::formula_settings<T>{}));
    CHECK_NOTHROW(aaf::validate(aaf::filter_settings<T>{}));
    CHECK_NOTHROW(aaf::validate(aaf::frame_settings<T>{}));
    {
        aaf::formula_settings<T> ok;
        ok.mu = T(1);  // the minimum alias-free rate is allowed
        CHECK_NOTHROW(aaf::validate(ok));
    }
    struct formula_case {
        const char* field;
        T aaf::formula_settings<T>::*member;
        T value;
    };
    const formula_case formula_cases[] = {
        {"settings.formulas.k", &aaf::formula_settings<T>::k, T(0)},
        {"settings.formulas.k", &aaf::formula_settings<T>::k, T(-1)},
        {"settings.formulas.k", &aaf::formula_settings<T>::k, nan},
        {"settings.formulas.k", &aaf::formula_settings<T>::k, inf},
        {"settings.formulas.mu", &aaf::formula_settings<T>::mu, T(0.999)},
        {"settings.formulas.mu", &aaf::formula_settings<T>::mu, T(0)},
        {"settings.formulas.mu", &aaf::formula_settings<T>::mu, nan},
        {"settings.formulas.mu", &aaf::formula_settings<T>::mu, inf},
        {"settings.formulas.alpha", &aaf::formula_settings<T>::alpha, T(0)},
        {"settings.formulas.alpha", &aaf::formula_settings<T>::alpha, T(-2)},
        {"settings.formulas.alpha", &aaf::formula_settings<T>::alpha, nan},
        {"settings.formulas.max_slope", &aaf::formula_settings<T>::max_slope, T(0)},
        {"settings.formulas.max_slope", &aaf::formula_settings<T>::max_slope, T(-1)},
        {"settings.formulas.max_slope", &aaf::formula_settings<T>::max_slope, nan},
    };
    for (const formula_case& c : formula_cases) {
        aaf::formula_settings<T> s;
        s.*c.member = c.value;
        INFO(c.field << " = " << c.value);
        CHECK_THROWS_AS(aaf::validate(s), aaf::invalid_argument);
        const std::string w = what_of([&] { aaf::validate(s, "my_function"); });
        CHECK(contains(w, c.field));
        CHECK(contains(w, "my_function"));
        // Through the frame settings too.
        aaf::frame_settings<T> fs;
        fs.formulas = s;
        CHECK(contains(what_of([&] { aaf::validate(fs); }), c.field));
    }
    struct filter_case {
        const char* field;
        void (*apply)(aaf::filter_settings<T>&);
    };
    const filter_case filter_cases[] = {
        {"settings.filter.truncation", [](aaf::filter_settings<T>& s) { s.truncation = T(0); }},
        {"settings.filter.truncation", [](aaf::filter_settings<T>& s) { s.truncation = T(-1); }},
        {"settings.filter.truncation", [](aaf::filter_settings<T>& s) { s.truncation = T(10.5); }},
        {"settings.filter.truncation", [](aaf::filter_settings<T>& s) { s.truncation = std::numeric_limits<T>::quiet_NaN(); }},
        {"settings.filter.truncation", [](aaf::filter_settings<T>& s) { s.truncation = std::numeric_limits<T>::infinity(); }},
        {"settings.filter.max_radius", [](aaf::filter_settings<T>& s) { s.max_radius = 1025; }},
        {"settings.filter.normal_threshold_degrees", [](aaf::filter_settings<T>& s) { s.normal_threshold_degrees = T(0); }},
        {"settings.filter.normal_threshold_degrees", [](aaf::filter_settings<T>& s) { s.normal_threshold_degrees = T(181); }},
        {"settings.filter.normal_threshold_degrees",
         [](aaf::filter_settings<T>& s) { s.normal_threshold_degrees = std::numeric_limits<T>::quiet_NaN(); }},
        {"settings.filter.spread_radius", [](aaf::filter_settings<T>& s) { s.spread_radius = 1025; }},
    };
    for (const filter_case& c : filter_cases) {
        aaf::filter_settings<T> s;
        c.apply(s);
        INFO(c.field);
        CHECK_THROWS_AS(aaf::validate(s), aaf::invalid_argument);
        CHECK(contains(what_of([&] { aaf::validate(s); }), c.field));
        aaf::frame_settings<T> fs;
        fs.filter = s;
        CHECK(contains(what_of([&] { aaf::validate(fs, "render_frame"); }), c.field));
    }
    {
        aaf::filter_settings<T> edge;
        edge.truncation = T(10);
        edge.max_radius = 1024;
        edge.normal_threshold_degrees = T(180);
        edge.spread_radius = 1024;
        CHECK_NOTHROW(aaf::validate(edge));
    }
    for (T radiance : {T(-1), nan, inf}) {
        aaf::frame_settings<T> fs;
        fs.radiance = radiance;
        INFO("radiance = " << radiance);
        CHECK(contains(what_of([&] { aaf::validate(fs); }), "settings.radiance"));
    }
}

TEST_CASE("validate() rejects invalid sampling settings, naming the field", "[formulas][settings]") {
    CHECK_NOTHROW(aaf::validate(aaf::sampling_settings{}));
    {
        aaf::sampling_settings s;
        s.initial_samples = 4096;
        s.max_samples = 1u << 20;
        CHECK_NOTHROW(aaf::validate(s));
        s.initial_samples = s.max_samples = 1;
        CHECK_NOTHROW(aaf::validate(s));
    }
    struct sampling_case {
        const char* field;
        std::uint32_t initial, max;
    };
    const sampling_case cases[] = {
        {"settings.sampling.initial_samples", 0, 100},
        {"settings.sampling.initial_samples", 4097, 5000},
        {"settings.sampling.max_samples", 9, 8},
        {"settings.sampling.max_samples", 9, 0},
        {"settings.sampling.max_samples", 9, (1u << 20) + 1},
    };
    for (const sampling_case& c : cases) {
        aaf::sampling_settings s;
        s.initial_samples = c.initial;
        s.max_samples = c.max;
        INFO(c.field << " initial=" << c.initial << " max=" << c.max);
        CHECK_THROWS_AS(aaf::validate(s), aaf::invalid_argument);
        CHECK(contains(what_of([&] { aaf::validate(s); }), c.field));
        aaf::frame_settings<float> fs;
        fs.sampling = s;
        CHECK(contains(what_of([&] { aaf::validate(fs); }), c.field));
    }
}

TEST_CASE("an infinite max_slope is rejected by validate", "[formulas][errors]") {
    aaf::formula_settings<float> f;
    f.max_slope = std::numeric_limits<float>::infinity();
    CHECK_THROWS_WITH(aaf::validate(f), Catch::Contains("settings.formulas.max_slope"));
}
