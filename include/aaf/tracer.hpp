// SPDX-License-Identifier: MIT
#pragma once
// The contract between aaf and the user's ray tracer: C++20 concepts, adapters and dispatch.
//
// THE TRACER CONTRACT
// -------------------
// aaf asks one question of a ray tracer: along a *shadow segment* from a receiver point towards a point
// on the light, where are the occluders? A segment is {origin, direction, length}: `origin` is the
// receiver point (already offset off its surface by aaf, see ray_offset.hpp, so no epsilon is needed),
// `direction` is a unit vector, and the light point is `origin + length * direction`. Distances are
// world units measured from `origin` along `direction`.
//
// A tracer is any object with at least one of these const member functions (pick the richest you can):
//
//   occluder_span<T> occluder_span(const shadow_segment<T>&) const;   // nearest AND farthest hit
//   T                nearest_occluder(const shadow_segment<T>&) const; // nearest hit only
//   void trace_batch(std::span<const shadow_segment<T>>, std::span<occluder_span<T>>) const;
//
// * Only hits with 0 < t < length count. The light's own geometry, if the scene contains it, must not be
//   reported (it sits at t = length); aaf discards anything at t >= length anyway.
// * A miss is `aaf::no_occluder<T>` (+infinity) from `nearest_occluder`, or an `occluder_span` whose
//   `hit()` is false (the default-constructed value) from `occluder_span` / `trace_batch`.
// * `nearest` is the hit closest to the receiver (it gives d2max, the occluder nearest the receiver).
//   `farthest` is the hit closest to the light (it gives d2min). Reporting only the nearest is the
//   "first hit" variant of FORMULAS.md §1.3: slopes s1 are then underestimated where several occluders
//   overlap; reporting both is the authors' "all hits" variant.
// * A NaN distance means "this sample failed"; aaf drops the sample rather than guess.
// * `trace_batch` receives all segments of one pixel and one pass at once (9 to ~100), for tracers with
//   packet or stream APIs (e.g. Embree's rtcOccluded16); `out` has the same size as the input.
// * Calls are made CONCURRENTLY from the executor's threads, on the same tracer object: the functions
//   must be safe to call from several threads at once (a const BVH traversal is).
//
// A tracer that can only answer "occluded or not" is adapted by `bisecting_tracer`, which finds the
// nearest occluder by bisection with a few extra boolean rays per occluded sample.
//
// Optionally a tracer may also have
//
//   bool occluded(const shadow_segment<T>&) const;                  // any hit in (0, length)?
//
// which the adaptive pass uses when it only needs visibility (sampling_settings::adaptive_query =
// shadow_query::visibility, the default): an any-hit ray is much cheaper than finding both span ends.
// Without it, that pass uses the query above and ignores the distances.

#include <concepts>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>

#include <glm/vec3.hpp>

#include "config.hpp"

namespace aaf {
inline namespace v0 {

/// A shadow ray from a receiver point towards a light point. See the contract above.
template <class T = float>
struct shadow_segment {
    glm::vec<3, T> origin{0};     ///< receiver point, already offset off the surface (world units)
    glm::vec<3, T> direction{0};  ///< unit vector towards the light point
    T length = 0;                 ///< distance from origin to the light point (world units)
};

/// Miss value of `nearest_occluder`.
template <class T = float>
inline constexpr T no_occluder = std::numeric_limits<T>::infinity();

/// The occluders found along one segment: distances from the origin of the hit nearest the receiver
/// and of the hit nearest the light. Default-constructed = miss.
template <class T = float>
struct occluder_span {
    T nearest = std::numeric_limits<T>::infinity();    ///< hit closest to the receiver
    T farthest = -std::numeric_limits<T>::infinity();  ///< hit closest to the light (== nearest for one hit)
    [[nodiscard]] constexpr bool hit() const noexcept { return nearest <= farthest; }
};

/// A tracer reporting the nearest and farthest occluder ("all hits" statistics).
template <class Tracer, class T = float>
concept span_tracer = requires(const Tracer& tracer, const shadow_segment<T>& segment) {
    { tracer.occluder_span(segment) } -> std::convertible_to<occluder_span<T>>;
};

/// A tracer reporting the nearest occluder distance only ("first hit" statistics).
template <class Tracer, class T = float>
concept nearest_tracer = requires(const Tracer& tracer, const shadow_segment<T>& segment) {
    { tracer.nearest_occluder(segment) } -> std::convertible_to<T>;
};

/// A tracer taking all of one pixel's segments at once (packet / stream tracers).
template <class Tracer, class T = float>
concept batch_tracer = requires(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                                std::span<occluder_span<T>> out) {
    { tracer.trace_batch(segments, out) };
};

/// A tracer that only answers "occluded or not"; needs `bisecting_tracer` to be used by aaf.
template <class Tracer, class T = float>
concept boolean_tracer = requires(const Tracer& tracer, const shadow_segment<T>& segment) {
    { tracer.occluded(segment) } -> std::convertible_to<bool>;
};

/// What aaf's gathering functions accept.
template <class Tracer, class T = float>
concept occlusion_tracer = span_tracer<Tracer, T> || nearest_tracer<Tracer, T> || batch_tracer<Tracer, T>;

/// Adapts a boolean-only tracer: an occluded segment is bisected `refine_steps` times on its prefix
/// [0, m] to bracket the nearest occluder; the bracket's midpoint is reported as both nearest and
/// farthest (first-hit statistics, with a distance error of at most length / 2^(steps+1)).
/// Costs 1 ray per unoccluded sample and 1 + refine_steps rays per occluded one.
template <class Tracer>
struct bisecting_tracer {
    const Tracer* tracer = nullptr;  ///< the wrapped boolean tracer (not owned)
    unsigned refine_steps = 5;       ///< bisection steps per occluded sample (0..30)

    template <class T>
        requires boolean_tracer<Tracer, T>
    [[nodiscard]] occluder_span<T> occluder_span(const shadow_segment<T>& segment) const {
        if (!tracer->occluded(segment)) return {};
        T lo = 0, hi = segment.length;  // the nearest occluder lies in (lo, hi]
        for (unsigned i = 0; i < refine_steps; ++i) {
            const T mid = T(0.5) * (lo + hi);
            shadow_segment<T> prefix = segment;
            prefix.length = mid;
            if (tracer->occluded(prefix)) hi = mid;
            else lo = mid;
        }
        const T t = T(0.5) * (lo + hi);
        return {t, t};
    }

    /// The wrapped tracer's own answer: visibility-only queries (shadow_query::visibility) cost one ray.
    template <class T>
        requires boolean_tracer<Tracer, T>
    [[nodiscard]] bool occluded(const shadow_segment<T>& segment) const {
        return static_cast<bool>(tracer->occluded(segment));
    }
};

template <class Tracer>
bisecting_tracer(const Tracer*, unsigned = 5) -> bisecting_tracer<Tracer>;

namespace detail {

/// Keeps only hits inside (0, length); a NaN anywhere marks the sample as failed (nearest = NaN).
/// A span reports only its two ends: when one end is outside (e.g. the light's own geometry at
/// t = length), the end inside is the only hit known to count, and the span collapses onto it.
template <class T>
[[nodiscard]] constexpr occluder_span<T> sanitize(occluder_span<T> s, T length) noexcept {
    if (std::isnan(s.nearest) || std::isnan(s.farthest)) return {std::numeric_limits<T>::quiet_NaN(), T(0)};
    if (!s.hit()) return {};
    const bool near_inside = s.nearest > T(0) && s.nearest < length;
    const bool far_inside = s.farthest > T(0) && s.farthest < length;
    if (near_inside && far_inside) return s;
    if (near_inside) return {s.nearest, s.nearest};
    if (far_inside) return {s.farthest, s.farthest};
    return {};
}

/// Traces one segment with whatever form the tracer offers.
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
[[nodiscard]] occluder_span<T> trace_one(const Tracer& tracer, const shadow_segment<T>& segment) {
    if constexpr (span_tracer<Tracer, T>) {
        return sanitize<T>(static_cast<occluder_span<T>>(tracer.occluder_span(segment)), segment.length);
    } else if constexpr (nearest_tracer<Tracer, T>) {
        const T t = static_cast<T>(tracer.nearest_occluder(segment));
        if (std::isnan(t)) return {t, T(0)};
        return sanitize<T>({t, t}, segment.length);
    } else {
        occluder_span<T> out{};
        tracer.trace_batch(std::span<const shadow_segment<T>>(&segment, 1), std::span<occluder_span<T>>(&out, 1));
        return sanitize<T>(out, segment.length);
    }
}

/// Traces a pixel's segments: one batch call when the tracer has one, else one call per segment.
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
void trace_all(const Tracer& tracer, std::span<const shadow_segment<T>> segments, std::span<occluder_span<T>> out) {
    if constexpr (batch_tracer<Tracer, T>) {
        tracer.trace_batch(segments, out);
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = sanitize<T>(out[i], segments[i].length);
    } else {
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = trace_one<T>(tracer, segments[i]);
    }
}

/// What a visibility-only query found along one segment.
enum class visibility_hit : unsigned char { visible, blocked, failed };

/// Traces a pixel's segments for visibility only: the tracer's `occluded` when it has one (it must follow
/// the contract's 0 < t < length itself; a bool cannot be sanitised), else its distance query with the
/// distances dropped after sanitising (a NaN still fails the sample). `hits` is scratch of the same size.
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
void trace_visibility(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                      std::span<occluder_span<T>> hits, std::span<visibility_hit> out) {
    if constexpr (boolean_tracer<Tracer, T>) {
        (void)hits;
        for (std::size_t i = 0; i < segments.size(); ++i)
            out[i] = tracer.occluded(segments[i]) ? visibility_hit::blocked : visibility_hit::visible;
    } else {
        trace_all<T>(tracer, segments, hits);
        for (std::size_t i = 0; i < segments.size(); ++i)
            out[i] = std::isnan(hits[i].nearest) || std::isnan(hits[i].farthest) ? visibility_hit::failed
                     : hits[i].hit()                                                ? visibility_hit::blocked
                                                                                    : visibility_hit::visible;
    }
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf
