// SPDX-License-Identifier: MIT
#pragma once
// Consistent progressive refinement (FORMULAS.md §1.10): a pixel's occlusion statistics are kept across
// passes (or frames of a still camera), every pass adds samples, and the filter narrows as they grow —
// each pixel's μ rises until the formulas' sample count n(μ) (§1.9) matches the samples it has, so
// β ∝ 1/μ → 0 — and the result converges to the Monte Carlo reference with no residual bias, where a
// frame at a fixed μ keeps its filter's bias however many samples it averages.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>

#include "../area_light.hpp"
#include "../executor.hpp"
#include "../filter.hpp"
#include "../footprint.hpp"
#include "../formulas.hpp"
#include "../gather.hpp"
#include "../guides.hpp"
#include "../image.hpp"
#include "../occlusion_stats.hpp"
#include "../pipeline.hpp"
#include "../settings.hpp"
#include "../tracer.hpp"

namespace aaf {
inline namespace v0 {

/// How μ rises from pass to pass.
enum class mu_schedule {
    /// Per pixel, the μ ≥ μ_1 whose sample count n(μ) (formulas.hpp sample_count, FORMULAS.md §1.9) equals
    /// the samples the pixel has accumulated: the filter is as narrow as the pixel's samples allow without
    /// aliasing, by the paper's own rule (with the paper form n grows at least as μ², so μ → ∞ and β → 0 as
    /// samples grow). The default.
    matched_samples,
    /// μ_1 · p^γ for every pixel after p passes (γ = progressive_settings::mu_exponent); 0 = fixed μ.
    power,
};

/// Settings of progressive_shadow.
template <class T = float>
struct progressive_settings {
    /// Per pass: `sampling.initial_samples` samples per pixel with nearest/farthest occluder distances
    /// (sample pass p of the key, so passes are independent; `adaptive` and `max_samples` are not used),
    /// `formulas` with `mu` as μ_1 (the first pass's), and `filter` as in render_frame.
    frame_settings<T> frame{};
    mu_schedule schedule = mu_schedule::matched_samples;  ///< how μ rises
    /// γ of mu_schedule::power, μ_p = μ_1 · p^γ; [0, 4]. 0 = a fixed μ (not consistent: for comparison).
    T mu_exponent = T(0.5);
};

/// Throws aaf::invalid_argument naming the first invalid field.
template <class T>
void validate(const progressive_settings<T>& s, const char* function = "validate") {
    validate(s.frame, function);
    if (s.schedule != mu_schedule::matched_samples && s.schedule != mu_schedule::power)
        detail::throw_invalid(function, "`settings.schedule` must be mu_schedule::matched_samples or mu_schedule::power");
    if (!(s.mu_exponent >= T(0) && s.mu_exponent <= T(4)))
        detail::throw_invalid(function, "`settings.mu_exponent` must be in [0, 4] (got " + std::to_string(s.mu_exponent) + ")");
}

/// A still camera's shadow refined pass by pass. Holds every pixel's merged statistics and the filter's
/// buffers (allocated by `reset`, reused by every pass). Not thread-safe itself; each pass runs on `exec`.
///
///     aaf::progressive_shadow<float> prog;
///     prog.reset(w, h);
///     for (int p = 0; p < passes; ++p) prog.add_pass(gb, light, tracer, {out}, settings, pool);  // out improves
template <class T = float>
class progressive_shadow {
public:
    /// Forgets every sample (a new view) and sizes the buffers for a w×h frame.
    void reset(std::size_t w, std::size_t h) {
        ws_.resize(w, h);
        ws_.stats.fill(occlusion_stats<T>{});
        passes_ = 0;
        rays_ = 0;
    }

    /// Passes accumulated so far.
    [[nodiscard]] std::uint32_t passes() const noexcept { return passes_; }
    /// Shadow rays traced since `reset`.
    [[nodiscard]] std::uint64_t rays() const noexcept { return rays_; }
    /// μ of pass p (1-based) under mu_schedule::power: μ_1 · p^γ.
    [[nodiscard]] static T mu_of_pass(const progressive_settings<T>& s, std::uint32_t p) noexcept {
        return s.frame.formulas.mu * std::pow(static_cast<T>(std::max<std::uint32_t>(p, 1)), s.mu_exponent);
    }
    /// The buffers after the last pass (statistics, slopes, β, unfiltered and filtered visibility), for the debug views.
    [[nodiscard]] const frame_workspace<T>& workspace() const noexcept { return ws_; }

    /// Adds one pass of samples to every surface pixel, then writes the filtered visibility of all samples so
    /// far (with μ of this pass) to `out` as render_frame writes its outputs (sky 1, no light 0, clamped to [0, 1];
    /// a zero normal faces the light's centre) and counts the same misconfigured pixels (report.diagnose()).
    /// Call `reset` first; the G-buffer, light and `settings` except μ must stay the same between passes.
    /// Throws aaf::invalid_argument (before writing) on mismatched buffers or invalid settings.
    template <class Ids, class Tracer, class Exec = sequential_executor>
        requires occlusion_tracer<Tracer, T>
    frame_report add_pass(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer, const frame_outputs<T>& out,
                          const progressive_settings<T>& settings = {}, Exec&& exec = {}) {
        constexpr const char* fn = "progressive_shadow::add_pass";
        detail::require_gbuffer(fn, gb);
        detail::require_light(fn, light);
        validate(settings, fn);
        const std::size_t w = gb.width(), h = gb.height();
        if (ws_.stats.width() != w || ws_.stats.height() != h)
            detail::throw_invalid(fn, "the G-buffer is " + std::to_string(w) + "x" + std::to_string(h) + " but `reset` sized the accumulator " +
                                          std::to_string(ws_.stats.width()) + "x" + std::to_string(ws_.stats.height()));
        detail::require_size(fn, "outputs.visibility", out.visibility, w, h);
        detail::require_size_or_empty(fn, "outputs.shaded", out.shaded, w, h);
        detail::require_size_or_empty(fn, "outputs.unshadowed", out.unshadowed, w, h);

        using clock = std::chrono::steady_clock;
        frame_report report;
        const auto t_frame = clock::now();
        sampling_settings ss = settings.frame.sampling;
        ss.max_samples = std::max(ss.max_samples, ss.initial_samples);
        formula_settings<T> fs = settings.frame.formulas;
        fs.mu = mu_of_pass(settings, passes_ + 1);
        const T sigma = light.sigma();

        auto t0 = clock::now();
        // Sample pass `passes_`: the first pass draws exactly render_frame's (and Monte Carlo's) initial samples.
        report.initial_rays = gather_occlusion(gb, light, tracer, ss, passes_, ss.initial_samples, ws_.stats.view(), {}, exec);
        report.initial_ms = detail::ms_since(t0);
        ++passes_;
        rays_ += report.initial_rays;

        // Slopes from every sample so far (they only get better), spread, β at this pass's μ.
        t0 = clock::now();
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) ws_.slopes(x, y) = slopes(ws_.stats(x, y), fs.max_slope);
        });
        const auto id_guides = [&] {
            if constexpr (gbuffer<T, Ids>::has_ids) return guides<no_guide, Ids, no_guide>{{}, gb.ids, {}};
            else return guides<>{};
        }();
        if (settings.frame.filter.spread_slopes)
            spread_slopes<T>(ws_.slopes.view(), ws_.slope_scratch.view(), settings.frame.filter.spread_radius, id_guides, exec);
        const bool horizon_rule = settings.frame.filter.unfiltered_at_horizon;  // as render_frame
        const glm::vec<3, T> centre = light.center();
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    formula_settings<T> f = fs;
                    if (settings.schedule == mu_schedule::matched_samples)
                        f.mu = matched_mu(ws_.slopes(x, y), sigma, gb.pixel_size(x, y), f, static_cast<T>(ws_.stats(x, y).samples));
                    ws_.filter_width(x, y) = filter_width(ws_.slopes(x, y), sigma, gb.pixel_size(x, y), f);
                    if (horizon_rule && detail::straddles_horizon_at(gb, light, centre, x, y)) ws_.filter_width(x, y) = T(0);
                    ws_.raw_visibility(x, y) = ws_.stats(x, y).visibility();
                }
        });
        report.formulas_ms = detail::ms_since(t0);

        t0 = clock::now();
        detail::filter_frame_visibility<T, Ids>(gb, light, ws_, settings.frame.filter, detail::executor_ref(exec));  // as render_frame
        report.filter_ms = detail::ms_since(t0);

        detail::write_frame_outputs<T, Ids>(gb, light, ws_.stats.cview(), ws_.filtered.cview(), out, settings.frame.radiance,
                                            detail::executor_ref(exec), report);
        report.total_ms = detail::ms_since(t_frame);
        return report;
    }

    /// The μ ≥ f.mu at which sample_count(s, σ, d, ·) reaches `samples` (mu_schedule::matched_samples):
    /// n(μ) is non-decreasing in μ, so bisection on log μ; f.mu when n(f.mu) already covers them; 1e6 when
    /// n stays below (the authors' form saturates), which makes β negligible.
    [[nodiscard]] static T matched_mu(const slope_pair<T>& s, T sigma, T pixel_size, formula_settings<T> f, T samples) noexcept {
        const T lo_mu = f.mu;
        if (!(sample_count(s, sigma, pixel_size, f) < samples)) return lo_mu;
        T lo = std::log(lo_mu), hi = std::log(T(1e6));
        f.mu = T(1e6);
        if (sample_count(s, sigma, pixel_size, f) < samples) return T(1e6);
        for (int i = 0; i < 40; ++i) {
            const T mid = (lo + hi) / 2;
            f.mu = std::exp(mid);
            (sample_count(s, sigma, pixel_size, f) < samples ? lo : hi) = mid;
        }
        return std::exp(hi);
    }

private:
    frame_workspace<T> ws_;
    std::uint32_t passes_ = 0;
    std::uint64_t rays_ = 0;
};

}  // namespace v0
}  // namespace aaf
