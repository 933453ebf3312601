// SPDX-License-Identifier: MIT
#pragma once
// The AAF soft-shadow formulas written straight from the paper (Mehta, Wang, Ramamoorthi 2012) and the
// authors' code, as restated in /work/shared/reference/FORMULAS.md §1.2–§1.9. Plain double precision,
// no guards, no limits handled: this is the oracle for the library's formulas.hpp at interior points
// (σ > 0, d > 0, s1 ≥ s2 > 0) only. Every function is a literal transcription; nothing is simplified.

#include <algorithm>
#include <cmath>

namespace aaf_ref {

// ---- §1.2 The slopes ----------------------------------------------------------------------------

/// s1 = d1/d2min − 1 (the steepest slope; d2min is the occluder nearest the light). §1.2
inline double slope_s1(double d1, double d2min) { return d1 / d2min - 1.0; }

/// s2 = d1/d2max − 1 (the flattest slope; d2max is the occluder nearest the receiver). §1.2
inline double slope_s2(double d1, double d2max) { return d1 / d2max - 1.0; }

// ---- §1.4, §1.5, §1.6 Bandwidths --------------------------------------------------------------------

/// Light bandwidth Ω_L^max = 1/σ (reading A). §1.4
inline double light_bandwidth(double sigma) { return 1.0 / sigma; }

/// Pixel bandwidth Ω_pix^max = 1/d. §1.5
inline double pixel_bandwidth(double d) { return 1.0 / d; }

/// Receiver-space bandlimit Ω_x^max = α Ω_pix^max / (1 + s2) = α/(d(1 + s2)). §1.6
inline double receiver_bandlimit(double d, double s2, double alpha) { return alpha * pixel_bandwidth(d) / (1.0 + s2); }

// ---- §1.7 Filter bandwidth Ω* -----------------------------------------------------------------------

/// Paper form (implied by the β formula): Ω* = μ·min(Ω_L^max/s2, Ω_x^max) = μ·min(1/(σ s2), α/(d(1+s2))). §1.7
inline double omega_paper(double sigma, double d, double s2, double mu, double alpha) {
    return mu * std::min(light_bandwidth(sigma) / s2, receiver_bandlimit(d, s2, alpha));
}

/// Authors' form (computeWxf, with the α generalisation of [GLSL v2]): Ω* = min(μ/(σ s2), α/(d(1+s2))). §1.7
inline double omega_authors(double sigma, double d, double s2, double mu, double alpha) {
    return std::min(mu / (sigma * s2), receiver_bandlimit(d, s2, alpha));
}

// ---- §1.8 Filter width β ----------------------------------------------------------------------------

/// β = 1/(k Ω*). §1.8
inline double beta(double omega_star, double k) { return 1.0 / (k * omega_star); }

/// The paper's β written as in the crop: β = (1/k)(1/μ)·max[σ(d1/d2max − 1), 1/Ω_x^max]. §1.8
inline double beta_paper_crop(double sigma, double d, double s2, double k, double mu, double alpha) {
    return (1.0 / k) * (1.0 / mu) * std::max(sigma * s2, 1.0 / receiver_bandlimit(d, s2, alpha));
}

// ---- §1.9 Sampling rate n ---------------------------------------------------------------------------

/// Paper form: n = 4 (1 + μ s1/s2)² (μ (2/s2) √(A_p/A_l) + α (1 + s2)^-1)², with A_p = d², A_l = 4σ². §1.9
inline double n_paper(double sigma, double d, double s1, double s2, double mu, double alpha) {
    const double A_p = d * d;
    const double A_l = 4.0 * sigma * sigma;
    const double first = 1.0 + mu * s1 / s2;
    const double second = mu * (2.0 / s2) * std::sqrt(A_p / A_l) + alpha * std::pow(1.0 + s2, -1.0);
    return 4.0 * first * first * second * second;
}

/// Authors' form: n = 4 (α/(1 + s2) + d Ω*)² (1 + σ min(s1 Ω*, s1/(d(1 + s1))))², with Ω* the authors' Ω*
/// of §1.7 (the α generalisation: α/(1+s2) in place of 1/(1+s2)). §1.9
inline double n_authors(double sigma, double d, double s1, double s2, double mu, double alpha) {
    const double omega = omega_authors(sigma, d, s2, mu, alpha);
    const double first = alpha / (1.0 + s2) + d * omega;
    const double second = 1.0 + sigma * std::min(s1 * omega, s1 / (d * (1.0 + s1)));
    return 4.0 * first * first * second * second;
}

}  // namespace aaf_ref
