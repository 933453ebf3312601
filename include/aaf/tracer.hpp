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
// A tracer is any object with at least one of these const member functions giving distances (the first
// pass always needs them):
//
//   occluder_span<T> occluder_span(const shadow_segment<T>&) const;   // nearest AND farthest hit
//   T                nearest_occluder(const shadow_segment<T>&) const; // nearest hit only
//   void trace_batch(std::span<const shadow_segment<T>>, std::span<occluder_span<T>>) const;  // both, batched
//   void nearest_batch(std::span<const shadow_segment<T>>, std::span<T>) const;               // nearest, batched
//
// and optionally the visibility-only ("any hit") queries, which the adaptive pass uses when it only needs
// visibility (sampling_settings::adaptive_query = shadow_query::visibility, the default):
//
//   bool occluded(const shadow_segment<T>&) const;                                            // any hit?
//   void occluded_batch(std::span<const shadow_segment<T>>, std::span<bool>) const;           // any hit, batched
//
// * Only hits with 0 < t < length count. The light's own geometry, if the scene contains it, must not be
//   reported (it sits at t = length); aaf discards anything at t >= length anyway.
// * A miss is `aaf::no_occluder<T>` (+infinity) from `nearest_occluder` / `nearest_batch`, or an
//   `occluder_span` whose `hit()` is false (the default-constructed value) from `occluder_span` / `trace_batch`.
// * `nearest` is the hit closest to the receiver (it gives d2max, the occluder nearest the receiver).
//   `farthest` is the hit closest to the light (it gives d2min). Reporting only the nearest is the
//   "first hit" variant of FORMULAS.md §1.3: slopes s1 are then underestimated where several occluders
//   overlap; reporting both is the authors' "all hits" variant.
// * A NaN distance means "this sample failed"; aaf drops the sample rather than guess.
// * Batched forms receive the segments of one or more whole pixels of one pass at once (pixels of one
//   row, or of consecutive rows of a task, until at least sampling_settings::batch_rays segments, 64 by
//   default), so that 8- or 16-wide packets fill; `out` has the same size as the input. Segments of one
//   pixel share their origin; segments of a batch may start anywhere.
// * Calls are made CONCURRENTLY from the executor's threads, on the same tracer object: the functions
//   must be safe to call from several threads at once (a const BVH traversal is).
//
// WHICH FORM TO IMPLEMENT
// * Single-ray tracer (a BVH walked one ray at a time, rtcIntersect1/rtcOccluded1): `occluder_span` if one
//   traversal can return both ends (the examples' BVH does), else `nearest_occluder`; plus `occluded`.
//   An any-hit ray stops at its first hit: the adaptive pass (about half the rays) costs far less with it.
// * Packet or stream tracer (rtcIntersect16/rtcOccluded16, a GPU queue): `nearest_batch` (a packet returns
//   the nearest hit only; the farthest needs a second ray from the light, which costs more than it helps on
//   most scenes: DEVIATIONS.md "first hit") plus `occluded_batch`; `trace_batch` if the farthest is cheap (costs: file end).
// * A tracer with only `occluded` is adapted by `bisecting_tracer` (a few extra rays per occluded sample).
// aaf uses the richest statistic offered (both ends before the nearest only), batched when it is offered.
// To see what aaf detected in your tracer: `static_assert(aaf::batch_visibility_tracer<MyTracer>)` etc., or
// print `aaf::describe_tracer<MyTracer>()`. A member with one of these names that aaf cannot call (not
// const, wrong arguments) stops the compilation with a static_assert naming it (check_tracer).

#include <concepts>
#include <cmath>
#include <cstddef>
#include <algorithm>
#include <limits>
#include <memory>
#include <span>
#include <vector>

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

/// A tracer taking many segments at once and reporting both ends (packet / stream tracers).
template <class Tracer, class T = float>
concept batch_tracer = requires(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                                std::span<occluder_span<T>> out) {
    { tracer.trace_batch(segments, out) };
};

/// A tracer taking many segments at once and reporting the nearest occluder of each (+∞ = miss).
template <class Tracer, class T = float>
concept nearest_batch_tracer = requires(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                                        std::span<T> out) {
    { tracer.nearest_batch(segments, out) };
};

/// A tracer that only answers "occluded or not"; needs `bisecting_tracer` to be used by aaf.
template <class Tracer, class T = float>
concept boolean_tracer = requires(const Tracer& tracer, const shadow_segment<T>& segment) {
    { tracer.occluded(segment) } -> std::convertible_to<bool>;
};

/// A tracer answering "occluded or not" for many segments at once (any-hit packets, e.g. rtcOccluded16).
template <class Tracer, class T = float>
concept batch_visibility_tracer = requires(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                                           std::span<bool> out) {
    { tracer.occluded_batch(segments, out) };
};

/// What aaf's gathering functions accept: at least one query that gives distances.
template <class Tracer, class T = float>
concept occlusion_tracer =
    span_tracer<Tracer, T> || nearest_tracer<Tracer, T> || batch_tracer<Tracer, T> || nearest_batch_tracer<Tracer, T>;

/// Whether aaf hands this tracer several pixels' segments per call for `visibility_only` queries (or for
/// distance queries): it has a batched form of the query aaf will use.
template <class Tracer, class T = float>
[[nodiscard]] constexpr bool uses_batches(bool visibility_only) noexcept {
    if (visibility_only && (batch_visibility_tracer<Tracer, T> || boolean_tracer<Tracer, T>))
        return batch_visibility_tracer<Tracer, T>;
    if constexpr (span_tracer<Tracer, T> || batch_tracer<Tracer, T>) return batch_tracer<Tracer, T>;
    else return nearest_batch_tracer<Tracer, T>;
}

/// The queries aaf will make of `Tracer`, in words (for a log line when integrating a tracer).
template <class Tracer, class T = float>
[[nodiscard]] constexpr const char* describe_tracer() noexcept {
    constexpr bool vb = batch_visibility_tracer<Tracer, T>, vs = boolean_tracer<Tracer, T>;
    if constexpr (batch_tracer<Tracer, T>)
        return vb ? "distances: trace_batch (nearest and farthest, batched); visibility: occluded_batch"
               : vs ? "distances: trace_batch (nearest and farthest, batched); visibility: occluded"
                    : "distances: trace_batch (nearest and farthest, batched); visibility: trace_batch";
    else if constexpr (span_tracer<Tracer, T>)
        return vb ? "distances: occluder_span (nearest and farthest); visibility: occluded_batch"
               : vs ? "distances: occluder_span (nearest and farthest); visibility: occluded"
                    : "distances: occluder_span (nearest and farthest); visibility: occluder_span";
    else if constexpr (nearest_batch_tracer<Tracer, T>)
        return vb ? "distances: nearest_batch (nearest only, batched); visibility: occluded_batch"
               : vs ? "distances: nearest_batch (nearest only, batched); visibility: occluded"
                    : "distances: nearest_batch (nearest only, batched); visibility: nearest_batch";
    else if constexpr (nearest_tracer<Tracer, T>)
        return vb ? "distances: nearest_occluder (nearest only); visibility: occluded_batch"
               : vs ? "distances: nearest_occluder (nearest only); visibility: occluded"
                    : "distances: nearest_occluder (nearest only); visibility: nearest_occluder";
    else
        return "not a tracer: no query that gives distances (see tracer.hpp)";
}

namespace detail {
// Whether the tracer has a plain (non-template, non-overloaded) member of that name, callable or not: such
// a member that aaf cannot call is a mistake worth stopping the compilation for.
template <class X> concept has_occluder_span_member = requires { &X::occluder_span; };
template <class X> concept has_nearest_occluder_member = requires { &X::nearest_occluder; };
template <class X> concept has_trace_batch_member = requires { &X::trace_batch; };
template <class X> concept has_nearest_batch_member = requires { &X::nearest_batch; };
template <class X> concept has_occluded_member = requires { &X::occluded; };
template <class X> concept has_occluded_batch_member = requires { &X::occluded_batch; };
// ... and whether it could be called on a non-const tracer (the usual mistake: a missing `const`).
template <class X, class T> concept mutable_occluder_span = requires(X& x, const shadow_segment<T>& s) {
    { x.occluder_span(s) } -> std::convertible_to<occluder_span<T>>;
};
template <class X, class T> concept mutable_nearest_occluder = requires(X& x, const shadow_segment<T>& s) {
    { x.nearest_occluder(s) } -> std::convertible_to<T>;
};
template <class X, class T> concept mutable_trace_batch = requires(X& x, std::span<const shadow_segment<T>> s, std::span<occluder_span<T>> o) {
    { x.trace_batch(s, o) };
};
template <class X, class T> concept mutable_nearest_batch = requires(X& x, std::span<const shadow_segment<T>> s, std::span<T> o) {
    { x.nearest_batch(s, o) };
};
template <class X, class T> concept mutable_occluded = requires(X& x, const shadow_segment<T>& s) {
    { x.occluded(s) } -> std::convertible_to<bool>;
};
template <class X, class T> concept mutable_occluded_batch = requires(X& x, std::span<const shadow_segment<T>> s, std::span<bool> o) {
    { x.occluded_batch(s, o) };
};
}  // namespace detail

/// Why `Tracer` cannot be used as is (or would have a query silently ignored), in words; nullptr when it can. check_tracer stops the compilation
/// with the same reasons; this form lets a test or a log say it.
template <class Tracer, class T = float>
[[nodiscard]] constexpr const char* tracer_problem() noexcept {
    using namespace detail;
    constexpr bool usable = occlusion_tracer<Tracer, T>;
    if constexpr (has_occluder_span_member<Tracer> && !span_tracer<Tracer, T> && (mutable_occluder_span<Tracer, T> || !usable))
        return mutable_occluder_span<Tracer, T> ? "`occluder_span` is not const" : "`occluder_span` has the wrong signature";
    if constexpr (has_nearest_occluder_member<Tracer> && !nearest_tracer<Tracer, T> && (mutable_nearest_occluder<Tracer, T> || !usable))
        return mutable_nearest_occluder<Tracer, T> ? "`nearest_occluder` is not const" : "`nearest_occluder` has the wrong signature";
    if constexpr (has_trace_batch_member<Tracer> && !batch_tracer<Tracer, T> && (mutable_trace_batch<Tracer, T> || !usable))
        return mutable_trace_batch<Tracer, T> ? "`trace_batch` is not const" : "`trace_batch` has the wrong signature";
    if constexpr (has_nearest_batch_member<Tracer> && !nearest_batch_tracer<Tracer, T> && (mutable_nearest_batch<Tracer, T> || !usable))
        return mutable_nearest_batch<Tracer, T> ? "`nearest_batch` is not const" : "`nearest_batch` has the wrong signature";
    if constexpr (has_occluded_member<Tracer> && !boolean_tracer<Tracer, T> && (mutable_occluded<Tracer, T> || !usable))
        return mutable_occluded<Tracer, T> ? "`occluded` is not const" : "`occluded` has the wrong signature";
    if constexpr (has_occluded_batch_member<Tracer> && !batch_visibility_tracer<Tracer, T> && (mutable_occluded_batch<Tracer, T> || !usable))
        return mutable_occluded_batch<Tracer, T> ? "`occluded_batch` is not const" : "`occluded_batch` has the wrong signature";
    if constexpr (!occlusion_tracer<Tracer, T>)
        return boolean_tracer<Tracer, T> || batch_visibility_tracer<Tracer, T>
                   ? "the tracer answers only `occluded`: wrap it in aaf::bisecting_tracer"
                   : "the tracer has no query that gives distances";
    return nullptr;
}

/// Stops the compilation with a message naming the member and the reason when `Tracer` has a member of
/// the contract that aaf cannot call (not const; or the wrong signature when nothing else gives distances),
/// or no query giving distances. Every entry point taking a tracer
/// calls it; call it yourself next to your tracer to check it where you write it.
template <class Tracer, class T = float>
consteval bool check_tracer() {
    using namespace detail;
    // A member of the contract's name that is callable with aaf's arguments on a non-const tracer is a missing
    // `const` (aaf would silently ignore it). One with other arguments is a mistake when the tracer has no
    // usable distance query; otherwise it may be the tracer's own overload, and is left alone.
    constexpr bool usable = occlusion_tracer<Tracer, T>;
    static_assert(!(has_occluder_span_member<Tracer> && !span_tracer<Tracer, T> && mutable_occluder_span<Tracer, T>),
                  "aaf tracer: `occluder_span` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_occluder_span_member<Tracer> && !span_tracer<Tracer, T> && !mutable_occluder_span<Tracer, T> && !usable),
                  "aaf tracer: `occluder_span` must be callable as occluder_span(const aaf::shadow_segment<T>&) const "
                  "and return aaf::occluder_span<T>, T being the frame's scalar type (tracer.hpp)");
    static_assert(!(has_nearest_occluder_member<Tracer> && !nearest_tracer<Tracer, T> && mutable_nearest_occluder<Tracer, T>),
                  "aaf tracer: `nearest_occluder` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_nearest_occluder_member<Tracer> && !nearest_tracer<Tracer, T> && !mutable_nearest_occluder<Tracer, T> && !usable),
                  "aaf tracer: `nearest_occluder` must be callable as nearest_occluder(const aaf::shadow_segment<T>&) "
                  "const and return T, T being the frame's scalar type (tracer.hpp)");
    static_assert(!(has_trace_batch_member<Tracer> && !batch_tracer<Tracer, T> && mutable_trace_batch<Tracer, T>),
                  "aaf tracer: `trace_batch` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_trace_batch_member<Tracer> && !batch_tracer<Tracer, T> && !mutable_trace_batch<Tracer, T> && !usable),
                  "aaf tracer: `trace_batch` must be callable as trace_batch(std::span<const aaf::shadow_segment<T>>, "
                  "std::span<aaf::occluder_span<T>>) const (tracer.hpp)");
    static_assert(!(has_nearest_batch_member<Tracer> && !nearest_batch_tracer<Tracer, T> && mutable_nearest_batch<Tracer, T>),
                  "aaf tracer: `nearest_batch` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_nearest_batch_member<Tracer> && !nearest_batch_tracer<Tracer, T> && !mutable_nearest_batch<Tracer, T> && !usable),
                  "aaf tracer: `nearest_batch` must be callable as nearest_batch(std::span<const aaf::shadow_segment<T>>, "
                  "std::span<T>) const (tracer.hpp)");
    static_assert(!(has_occluded_member<Tracer> && !boolean_tracer<Tracer, T> && mutable_occluded<Tracer, T>),
                  "aaf tracer: `occluded` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_occluded_member<Tracer> && !boolean_tracer<Tracer, T> && !mutable_occluded<Tracer, T> && !usable),
                  "aaf tracer: `occluded` must be callable as occluded(const aaf::shadow_segment<T>&) const and return "
                  "bool (tracer.hpp)");
    static_assert(!(has_occluded_batch_member<Tracer> && !batch_visibility_tracer<Tracer, T> && mutable_occluded_batch<Tracer, T>),
                  "aaf tracer: `occluded_batch` must be a const member function: aaf calls the tracer through a const "
                  "reference, from several threads at once (tracer.hpp)");
    static_assert(!(has_occluded_batch_member<Tracer> && !batch_visibility_tracer<Tracer, T> && !mutable_occluded_batch<Tracer, T> && !usable),
                  "aaf tracer: `occluded_batch` must be callable as occluded_batch(std::span<const "
                  "aaf::shadow_segment<T>>, std::span<bool>) const (tracer.hpp)");
    static_assert(occlusion_tracer<Tracer, T> || !(boolean_tracer<Tracer, T> || batch_visibility_tracer<Tracer, T>),
                  "aaf tracer: the tracer answers only `occluded` (no distances, which the first pass needs): wrap it, "
                  "aaf::bisecting_tracer{&tracer}");
    constexpr bool named = has_occluder_span_member<Tracer> || has_nearest_occluder_member<Tracer> ||
                           has_trace_batch_member<Tracer> || has_nearest_batch_member<Tracer>;  // reported above
    static_assert(occlusion_tracer<Tracer, T> || boolean_tracer<Tracer, T> || batch_visibility_tracer<Tracer, T> || named,
                  "aaf tracer: the tracer has none of occluder_span, nearest_occluder, trace_batch, nearest_batch as a "
                  "const member function (tracer.hpp lists them with their signatures)");
    return true;
}

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

/// The result of a nearest-only query as a span (a NaN marks a failed sample; a miss is +∞ or anything ≥ length).
template <class T>
[[nodiscard]] constexpr occluder_span<T> nearest_span(T t, T length) noexcept {
    if (std::isnan(t)) return {t, T(0)};
    return sanitize<T>({t, t}, length);
}

/// Traces one segment with whatever form the tracer offers (the richest statistic first).
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
[[nodiscard]] occluder_span<T> trace_one(const Tracer& tracer, const shadow_segment<T>& segment) {
    if constexpr (span_tracer<Tracer, T>) {
        return sanitize<T>(static_cast<occluder_span<T>>(tracer.occluder_span(segment)), segment.length);
    } else if constexpr (batch_tracer<Tracer, T>) {
        occluder_span<T> out{};
        tracer.trace_batch(std::span<const shadow_segment<T>>(&segment, 1), std::span<occluder_span<T>>(&out, 1));
        return sanitize<T>(out, segment.length);
    } else if constexpr (nearest_tracer<Tracer, T>) {
        return nearest_span<T>(static_cast<T>(tracer.nearest_occluder(segment)), segment.length);
    } else {
        T t = no_occluder<T>;
        tracer.nearest_batch(std::span<const shadow_segment<T>>(&segment, 1), std::span<T>(&t, 1));
        return nearest_span<T>(t, segment.length);
    }
}

/// Scratch for the batched forms whose output is not an occluder_span (reused by a thread across calls).
template <class T>
struct trace_scratch {
    std::vector<T> nearest;                // nearest_batch's distances
    std::unique_ptr<bool[]> blocked;       // occluded_batch's answers
    std::size_t blocked_capacity = 0;

    [[nodiscard]] std::span<T> nearest_for(std::size_t n) {
        if (nearest.size() < n) nearest.resize(n);
        return {nearest.data(), n};
    }
    [[nodiscard]] std::span<bool> blocked_for(std::size_t n) {
        if (blocked_capacity < n) blocked.reset(new bool[n]), blocked_capacity = n;
        return {blocked.get(), n};
    }
};

/// Traces segments for their distances: one batch call when the tracer has a batched form of its richest
/// statistic, else one call per segment. Results equal trace_one's, segment by segment.
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
void trace_all(const Tracer& tracer, std::span<const shadow_segment<T>> segments, std::span<occluder_span<T>> out,
               trace_scratch<T>* scratch = nullptr) {
    if constexpr (batch_tracer<Tracer, T>) {
        tracer.trace_batch(segments, out);
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = sanitize<T>(out[i], segments[i].length);
    } else if constexpr (!span_tracer<Tracer, T> && nearest_batch_tracer<Tracer, T>) {
        trace_scratch<T> local;
        trace_scratch<T>& sc = scratch ? *scratch : local;
        const std::span<T> t = sc.nearest_for(segments.size());
        std::fill(t.begin(), t.end(), no_occluder<T>);
        tracer.nearest_batch(segments, t);
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = nearest_span<T>(t[i], segments[i].length);
    } else {
        (void)scratch;
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = trace_one<T>(tracer, segments[i]);
    }
}

/// What a visibility-only query found along one segment.
enum class visibility_hit : unsigned char { visible, blocked, failed };

/// Traces segments for visibility only: the tracer's `occluded_batch` or `occluded` when it has one (it
/// must follow the contract's 0 < t < length itself; a bool cannot be sanitised), else its distance query
/// with the distances dropped after sanitising (a NaN still fails the sample). `hits` is scratch of the
/// same size.
template <class T, class Tracer>
    requires occlusion_tracer<Tracer, T>
void trace_visibility(const Tracer& tracer, std::span<const shadow_segment<T>> segments,
                      std::span<occluder_span<T>> hits, std::span<visibility_hit> out, trace_scratch<T>* scratch = nullptr) {
    if constexpr (batch_visibility_tracer<Tracer, T>) {
        (void)hits;
        trace_scratch<T> local;
        trace_scratch<T>& sc = scratch ? *scratch : local;
        const std::span<bool> blocked = sc.blocked_for(segments.size());
        std::fill(blocked.begin(), blocked.end(), false);
        tracer.occluded_batch(segments, blocked);
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = blocked[i] ? visibility_hit::blocked : visibility_hit::visible;
    } else if constexpr (boolean_tracer<Tracer, T>) {
        (void)hits, (void)scratch;
        for (std::size_t i = 0; i < segments.size(); ++i)
            out[i] = tracer.occluded(segments[i]) ? visibility_hit::blocked : visibility_hit::visible;
    } else {
        trace_all<T>(tracer, segments, hits, scratch);
        for (std::size_t i = 0; i < segments.size(); ++i)
            out[i] = std::isnan(hits[i].nearest) || std::isnan(hits[i].farthest) ? visibility_hit::failed
                     : hits[i].hit()                                                ? visibility_hit::blocked
                                                                                    : visibility_hit::visible;
    }
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf

// MEASURED COSTS OF THE FORMS (the figures behind "WHICH FORM TO IMPLEMENT" above)
// benchmarks/bench_frame.cpp BM_frame_tracers (`scripts/bench --tracers`): render_frame on the bunny at 640x480,
// default settings, 14.7 rays per pixel, the same frame with every form in turns; AMD EPYC, AVX-512, 1 thread,
// medians of 5 at a load average of 8 on 2 cores. A frame's speed-up over the examples' BVH with
// occluder_span + occluded (2156 ms, 2.1 Mrays/s):
//   BVH nearest_occluder + occluded                       1.26x  (occluder_span: one traversal, but of the whole segment)
//   Embree 1 ray: occluder_span + occluded                1.59x  (occluder_span is two rtcIntersect1)
//   Embree 1 ray: nearest_occluder + occluded             1.85x
//   Embree packets: trace_batch + occluded_batch          2.05x  (batch_rays 64; 16: 2.02x, 256: 2.09x)
//   Embree packets: nearest_batch + occluded_batch        2.42x  (868 ms, 5.1 Mrays/s)
// So with Embree the batched forms are 1.3x its single rays, and leaving out the farthest hit saves another
// 15-17 % of the frame for an RMSE within 1.5 % of the all-hits one (docs/results, mu = 2: bunny 0.00459 vs
// 0.00458, plant 0.0109 vs 0.0107). batch_rays hardly matters: whole pixels' segments already fill the packets.
