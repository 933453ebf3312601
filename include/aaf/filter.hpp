// SPDX-License-Identifier: MIT
#pragma once
// The separable, spatially varying, guided Gaussian filter of visibility (FORMULAS.md §1.8, §1.11–§1.14)
// and the slope-spreading pass that gives unoccluded pixels their occluded neighbours' slopes (§1.12).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "config.hpp"
#include "executor.hpp"
#include "guides.hpp"
#include "image.hpp"
#include "image_view.hpp"
#include "occlusion_stats.hpp"
#include "settings.hpp"
#include "simd.hpp"
#include "simd_exp.hpp"
#include "tangent_frame.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {

enum class pass_direction { horizontal, vertical };

/// Kernel radius in pixels for a width of `beta_px` pixels.
template <class T>
[[nodiscard]] std::size_t kernel_radius(T beta_px, const filter_settings<T>& s) noexcept {
    if (!(beta_px > T(0))) return 0;
    const T r = std::ceil(s.truncation * beta_px);
    return r < static_cast<T>(s.max_radius) ? static_cast<std::size_t>(r) : s.max_radius;
}

/// For k = 1..radius: calls `step(k)`, then `f(k, nx, ny, v)` for the neighbours at distance k along `Dir`
/// from (x, y) (`pos` is x or y, `extent` the width or height) whose value v is finite and which the guides
/// accept. The one definition of "a tap", shared by the filter pass (whose `step` advances its weight
/// recurrence once per k, in the hot loop) and the non-finite-centre fallback.
template <pass_direction Dir, class T, class G, class Step, class F>
void for_each_accepted_tap(const_image_view<T> src, const G& g, const guide_center<T, G>& gc, std::size_t x, std::size_t y,
                           std::size_t pos, std::size_t extent, std::size_t radius, T cos_threshold, Step&& step,
                           F&& f) noexcept {
    for (std::size_t k = 1; k <= radius; ++k) {
        step(k);
        for (int side = -1; side <= 1; side += 2) {
            if (side < 0 ? k > pos : pos + k >= extent) continue;
            const std::size_t j = side < 0 ? pos - k : pos + k;
            const std::size_t nx = Dir == pass_direction::horizontal ? j : x;
            const std::size_t ny = Dir == pass_direction::horizontal ? y : j;
            const T v = src(nx, ny);
            if (!std::isfinite(v) || !gc.accepts(g, nx, ny, cos_threshold)) continue;
            f(k, nx, ny, v);
        }
    }
}

/// |d|² − (d·n)², clamped below at 0 (NaN stays NaN), for a scalar T or a vector of lanes: one source
/// expression for both, so that a compiler that contracts a·b + c into fma contracts both alike (the
/// light-plane lanes and the scalar rule then compute the same bits at any -march).
template <class V>
[[nodiscard]] V plane_distance2(V dx, V dy, V dz, V nx, V ny, V nz) noexcept {
    const V along = dx * nx + dy * ny + dz * nz;
    const V d2 = (dx * dx + dy * dy + dz * dz) - along * along;
    const V zero = V{};
    return zero > d2 ? zero : d2;  // the operand order of x86's max: one instruction
}

/// Squared distance between the centre `p` and a neighbour at `q`, projected on the plane of the unit
/// normal `n` (FORMULAS §1.11 [AUTH]): the tangent-plane filter's distance (n = the centre's normal).
template <class T>
[[nodiscard]] T light_plane_distance2(const glm::vec<3, T>& q, const glm::vec<3, T>& p, const glm::vec<3, T>& n) noexcept {
    const glm::vec<3, T> dp = q - p;
    return plane_distance2<T>(dp.x, dp.y, dp.z, n.x, n.y, n.z);
}

/// The same for neighbour (nx, ny) of the guides' positions.
template <class T, class G>
[[nodiscard]] T light_plane_distance2(const G& g, std::size_t nx, std::size_t ny, const glm::vec<3, T>& p,
                                      const glm::vec<3, T>& n) noexcept {
    return light_plane_distance2<T>(g.positions(nx, ny), p, n);
}

/// A position's coordinate along a basis axis, x·ex + y·ey + z·ez, with its roundings fixed: with an FMA
/// instruction fma(z, ez, fma(y, ey, x·ex)) explicitly, else three products and two sums. GCC contracts
/// a·b + c into an fma across statements, and which product it fuses depends on the code around it
/// (measured: a per-pixel evaluation compiled without inlining fused them otherwise at x86-64-v3), so the
/// plain expression gave a pixel's coordinates different bits in the row copies and in the scalar rule.
template <class T>
[[nodiscard]] inline T plane_coordinate(T x, T y, T z, const glm::vec<3, T>& axis) noexcept {
#if defined(__FMA__) || defined(__ARM_FEATURE_FMA)
    return std::fma(z, axis.z, std::fma(y, axis.y, x * axis.x));
#else
    return x * axis.x + y * axis.y + z * axis.z;  // no FMA instruction: nothing to contract
#endif
}

/// The light-plane filter's squared distance from the differences of two pixels' plane coordinates
/// (light_plane_coordinates), for a scalar T or a vector of lanes.
template <class V>
[[nodiscard]] V plane_coordinates_distance2(V du, V dv) noexcept {
    return du * du + dv * dv;
}

/// A position's light-plane coordinates (u, v) = (p·t, p·b) (FORMULAS §1.11 [BS]: positions mapped
/// through the basis (t, b, n) of tangent_frame(n), Duff et al. 2017, and the first two coordinates kept).
/// The light-plane filter's distance is (u_q − u_p)² + (v_q − v_p)² from these, computed once per pixel:
/// mathematically the projected distance |q − p|² − ((q − p)·n)² of [AUTH], in floating point rounded at
/// the scale of |p| (the distance from the world's origin) instead of |q − p|; docs/DEVIATIONS.md F3 gives
/// why and the measured difference. A position is usable when u + v is finite (a non-finite component
/// makes both non-finite).
template <class T>
[[nodiscard]] glm::vec<2, T> light_plane_coordinates(const glm::vec<3, T>& p, const tangent_frame<T>& basis) noexcept {
    return {plane_coordinate<T>(p.x, p.y, p.z, basis.t), plane_coordinate<T>(p.x, p.y, p.z, basis.b)};
}

/// The light-plane filter's squared distance between the centre at plane coordinates `p` and neighbour
/// (nx, ny) of the guides' positions.
template <class T, class G>
[[nodiscard]] T light_plane_coordinates_distance2(const G& g, std::size_t nx, std::size_t ny, const glm::vec<2, T>& p,
                                                  const tangent_frame<T>& basis) noexcept {
    const glm::vec<2, T> q = light_plane_coordinates<T>(g.positions(nx, ny), basis);
    return plane_coordinates_distance2<T>(q.x - p.x, q.y - p.y);
}

/// Whether a centre at `p` has a position the pass can use: its light-plane coordinates' sum is finite (the
/// lanes test u + v + 0, tap_rows::plane_coordinates), in the tangent plane its components' sum.
template <offset_space Space, class T>
[[nodiscard]] bool has_position(const glm::vec<3, T>& p, const tangent_frame<T>& basis) noexcept {
    if constexpr (Space == offset_space::light_plane) {
        const glm::vec<2, T> uv = light_plane_coordinates<T>(p, basis);
        return std::isfinite(uv.x + uv.y + T(0));
    } else {
        return std::isfinite(p.x + p.y + p.z);
    }
}

/// The result of a pass for a non-finite centre: the Gaussian average of its accepted finite neighbours.
/// Such a centre has no weight of its own, so the result is a ratio of neighbour weights only, and for a
/// narrow kernel every exp(−e) can underflow to 0 in T (e.g. β/d < 0.07 px in float: exp(−1/(2·0.07²)) = 0)
/// although valid neighbours exist. The weights are normalised, so evaluate them relative to the largest,
/// exp(−(e − e_min)); `centre` is returned only when no neighbour is accepted. On the light plane the
/// distance is the paper's |q − p|² − ((q − p)·n)², not the passes' plane coordinates (F3): relative to
/// the largest weight, the exponents' rounding at the scale of |p| would be amplified by their size (a
/// difference of 1.5e−4 from the double reference in tests/test_filter.cpp), and this rule is rare and scalar.
template <pass_direction Dir, offset_space Space, class T, class G>
[[nodiscard]] T non_finite_centre_average(const_image_view<T> src, const G& g, const guide_center<T, G>& gc,
                                          const glm::vec<3, T>& p, const glm::vec<3, T>& light_normal, std::size_t x,
                                          std::size_t y, std::size_t pos, std::size_t extent, std::size_t radius, T a,
                                          T inv_two_beta2, T cos_threshold, T centre) noexcept {
    const auto for_each_tap = [&](auto&& f) {
        for_each_accepted_tap<Dir>(src, g, gc, x, y, pos, extent, radius, cos_threshold, [](std::size_t) {},
                                   [&](std::size_t k, std::size_t nx, std::size_t ny, T v) {
                                       T e;
                                       if constexpr (Space == offset_space::light_plane)
                                           e = light_plane_distance2(g, nx, ny, p, light_normal) * inv_two_beta2;
                                       else if constexpr (Space == offset_space::tangent_plane)
                                           e = light_plane_distance2(g, nx, ny, p, gc.normal) * inv_two_beta2;
                                       else
                                           e = static_cast<T>(k) * static_cast<T>(k) * a;
                                       if (!std::isnan(e)) f(e, v);  // NaN position
                                   });
    };
    T e_min = std::numeric_limits<T>::infinity();
    for_each_tap([&](T e, T) { e_min = std::min(e_min, e); });
    if (!(e_min < std::numeric_limits<T>::infinity())) return centre;
    T sum = T(0), wsum = T(0);
    for_each_tap([&](T e, T v) {
        const T weight = std::exp(-(e - e_min));
        sum += weight * v;
        wsum += weight;
    });
    return sum / wsum;
}

// ---------------------------------------------------------------------------------------------------
// The fast pass. Pixels are processed as lanes: a row of centres, in blocks of `filter_lane_block`, with
// the tap distance k in the outer loop and the lanes in the inner loop, so that a lane's neighbours at
// ±k are contiguous in memory for both directions (x±k in the row; the same x in rows y±k). The inner
// loop is branch-free (a tap is a mask: in range, finite, same ID, normal within the threshold) and GCC
// and Clang vectorise it. Each lane performs exactly the arithmetic of the per-pixel definition
// (for_each_accepted_tap: k ascending, the −k side before the +k side, the same weight recurrence), so
// the result is the same number as a pixel-by-pixel loop, independent of blocks and threads.

#if defined(__GNUC__) || defined(__clang__) || defined(_MSC_VER)
#define AAF_DETAIL_RESTRICT __restrict
#else
#define AAF_DETAIL_RESTRICT
#endif

/// Rows of centres per task of a pass (the executor's unit of work): amortises the vertical pass's copy
/// of the rows within reach and leaves enough tasks to balance threads.
inline constexpr std::size_t filter_rows_per_task = 64;
/// Lanes whose accumulators stay together in L1 while k runs over the kernel.
inline constexpr std::size_t filter_lane_block = 64;
/// Distances per sweep over the lanes in image space (each lane's state is loaded and stored once per sweep).
inline constexpr std::size_t filter_distances_per_sweep = 2;  // 4 measured slower (GCC 12, AVX-512)

/// Copies row `y` of `view` to `out`; a plain array loop (vectorised) when the row is packed.
template <class U>
void copy_row(const_image_view<U> view, std::size_t y, U* AAF_DETAIL_RESTRICT out) noexcept {
    const std::size_t w = view.width();
    if (view.packed_rows()) {
        const U* AAF_DETAIL_RESTRICT in = &view(0, y);
        for (std::size_t x = 0; x < w; ++x) out[x] = in[x];
    } else {
        for (std::size_t x = 0; x < w; ++x) out[x] = view(x, y);
    }
}

/// Copies row `y` of a view of vectors to three component arrays.
template <class T>
void copy_row(const_image_view<glm::vec<3, T>> view, std::size_t y, T* AAF_DETAIL_RESTRICT ox, T* AAF_DETAIL_RESTRICT oy,
              T* AAF_DETAIL_RESTRICT oz) noexcept {
    const std::size_t w = view.width();
    if (view.packed_rows()) {
        const glm::vec<3, T>* AAF_DETAIL_RESTRICT in = &view(0, y);
        std::size_t x = 0;
#if AAF_SIMD_BYTES > 0
        if constexpr (sizeof(glm::vec<3, T>) == 3 * sizeof(T)) {  // GLM's packed layout (the default)
            using S = simd<T>;
            for (; x + S::lanes <= w; x += S::lanes) {
                typename S::vec vx, vy, vz;
                S::deinterleave3(&in[x].x, vx, vy, vz);
                S::store(ox + x, vx), S::store(oy + x, vy), S::store(oz + x, vz);
            }
        }
#endif
        for (; x < w; ++x) ox[x] = in[x].x, oy[x] = in[x].y, oz[x] = in[x].z;
    } else {
        for (std::size_t x = 0; x < w; ++x) {
            const glm::vec<3, T> n = view(x, y);
            ox[x] = n.x, oy[x] = n.y, oz[x] = n.z;
        }
    }
}

/// Row `y` of `view` as a plain array: in place when the row is packed, else copied to `scratch`.
template <class U>
[[nodiscard]] const U* row_of(const_image_view<U> view, std::size_t y, U* scratch) noexcept {
    if (view.packed_rows()) return &view(0, y);
    copy_row(view, y, scratch);
    return scratch;
}

/// Writes `in` to row `y` of `view`; a plain array loop (vectorised) when the row is packed.
template <class U>
void store_row(const U* AAF_DETAIL_RESTRICT in, image_view<U> view, std::size_t y) noexcept {
    const std::size_t w = view.width();
    if (view.packed_rows()) {
        U* AAF_DETAIL_RESTRICT out = &view(0, y);
        for (std::size_t x = 0; x < w; ++x) out[x] = in[x];
    } else {
        for (std::size_t x = 0; x < w; ++x) view(x, y) = in[x];
    }
}

/// The largest of `n` kernel radii held as T (whole numbers in [0, 1024]); an integer reduction, which
/// vectorises where a floating-point max does not (it would have to keep NaN semantics).
template <class T>
[[nodiscard]] std::size_t largest_radius(const T* AAF_DETAIL_RESTRICT radius, std::size_t n) noexcept {
    std::int32_t m = 0;
    for (std::size_t i = 0; i < n; ++i) m = std::max(m, static_cast<std::int32_t>(radius[i]));
    return static_cast<std::size_t>(m);
}

/// Pointers to one element of every array of a tap_rows (a lane block's neighbours on one side); the
/// guides a pass does not use stay null.
template <class T>
struct tap_cursor {
    const T* AAF_DETAIL_RESTRICT v;
    const T* AAF_DETAIL_RESTRICT nx;
    const T* AAF_DETAIL_RESTRICT ny;
    const T* AAF_DETAIL_RESTRICT nz;
    const std::uint32_t* AAF_DETAIL_RESTRICT id;
    const T* AAF_DETAIL_RESTRICT px;
    const T* AAF_DETAIL_RESTRICT py;
    const T* AAF_DETAIL_RESTRICT pz;
};

/// The memory of a pass's row copies (tap_rows), independent of the guides and offset space so that one
/// workspace serves every filter call of a frame loop; arrays a pass does not use stay empty.
template <class T>
struct row_buffers {
    std::vector<T> v, nx, ny, nz, px, py, pz;
    std::vector<std::uint32_t> id;
    std::vector<T> radius;  // filter_pass's `frame` only: each pixel's kernel radius, from the horizontal pass
};

/// Replaces `n` positions (x, y, z arrays) by their light-plane coordinates (u, v, 0): light_plane_coordinates's
/// bits (plane_coordinate's fixed roundings, which the compiler's vectorisation of this loop keeps).
template <class T>
void to_plane_coordinates(T* AAF_DETAIL_RESTRICT x, T* AAF_DETAIL_RESTRICT y, T* AAF_DETAIL_RESTRICT z, std::size_t n,
                          const tangent_frame<T>& basis) noexcept {
    for (std::size_t i = 0; i < n; ++i) {
        const T px = x[i], py = y[i], pz = z[i];
        x[i] = plane_coordinate(px, py, pz, basis.t);
        y[i] = plane_coordinate(px, py, pz, basis.b);
        z[i] = T(0);
    }
}

/// Structure-of-arrays copies of rows of the pass's input and of the guides it uses, `stride` elements per
/// row, so that the lanes read contiguous, aligned-type arrays whatever the caller's pixel strides.
/// Elements that stand for pixels outside the image hold a NaN value (and NaN normals), which every tap
/// rejects; with normals, a non-finite value also gets a NaN normal, so the normal test rejects it alone.
/// The arrays live in a row_buffers (a workspace's), which only grows.
template <class T, class G, offset_space Space>
struct tap_rows {
    static constexpr bool normals = G::has_normals;
    static constexpr bool ids = G::has_ids;
    static constexpr bool positions = Space != offset_space::image;
    /// Light plane: px, py hold each position's light-plane coordinates u, v (light_plane_coordinates) and
    /// pz holds 0, so that a centre's u + v + 0 is finite exactly when it has a usable position.
    static constexpr bool plane_coordinates = Space == offset_space::light_plane;
    std::size_t stride = 0;
    row_buffers<T>& buffers;
    tangent_frame<T> basis{glm::vec<3, T>(0, 0, 1)};  // light plane: set by the pass (its unit light normal)
    // Not cleared: every element is written by `load` or `fill` before the lanes read it.
    T *v = nullptr, *nx = nullptr, *ny = nullptr, *nz = nullptr, *px = nullptr, *py = nullptr, *pz = nullptr;
    std::uint32_t* id = nullptr;

    explicit tap_rows(row_buffers<T>& b) noexcept : buffers(b) {}

    /// Makes room for `rows` rows of `row_stride` elements; the buffers reallocate only to grow. `aligned`:
    /// every array starts on a 64-byte boundary (so that rows of a multiple of 64 bytes load aligned).
    void resize(std::size_t rows, std::size_t row_stride, bool aligned = false) {
        stride = row_stride;
        const std::size_t n = rows * row_stride;
        const auto fit = [n, aligned](auto& array) {
            using U = std::remove_reference_t<decltype(array[0])>;
            const std::size_t slack = aligned ? 64 / sizeof(U) : 0;
            if (array.size() < n + slack) array.resize(n + slack);
            const auto misaligned = reinterpret_cast<std::uintptr_t>(array.data()) % 64;
            return array.data() + (aligned && misaligned ? (64 - misaligned) / sizeof(U) : 0);
        };
        v = fit(buffers.v);
        if constexpr (normals) nx = fit(buffers.nx), ny = fit(buffers.ny), nz = fit(buffers.nz);
        if constexpr (ids) id = fit(buffers.id);
        if constexpr (positions) px = fit(buffers.px), py = fit(buffers.py), pz = fit(buffers.pz);
    }

    /// Makes elements [begin, end) of buffer row `row` stand for pixels outside the image (rejected taps).
    void fill(std::size_t row, std::size_t begin, std::size_t end) noexcept {
        constexpr T nan = std::numeric_limits<T>::quiet_NaN();
        const std::size_t o = row * stride;
        std::fill(&v[o + begin], &v[o + end], nan);
        if constexpr (normals) {
            std::fill(&nx[o + begin], &nx[o + end], nan);
            std::fill(&ny[o + begin], &ny[o + end], nan);
            std::fill(&nz[o + begin], &nz[o + end], nan);
        }
        if constexpr (ids) std::fill(&id[o + begin], &id[o + end], 0u);
        if constexpr (positions) {
            std::fill(&px[o + begin], &px[o + end], nan);
            std::fill(&py[o + begin], &py[o + end], nan);
            std::fill(&pz[o + begin], &pz[o + end], nan);
        }
    }

    /// Copies pixels [0, w) of image row `y` to elements [offset, offset + w) of buffer row `row`.
    void load(std::size_t row, std::size_t offset, const_image_view<T> src, const G& g, std::size_t y) noexcept {
        const std::size_t w = src.width(), o = row * stride + offset;
        copy_row(src, y, &v[o]);
        if constexpr (normals) {
            copy_row(g.normals, y, &nx[o], &ny[o], &nz[o]);
            // A non-finite value gets a NaN normal, so that the normal test alone rejects it.
            constexpr T max_finite = std::numeric_limits<T>::max(), nan = std::numeric_limits<T>::quiet_NaN();
            T* AAF_DETAIL_RESTRICT n = &nx[o];
            const T* AAF_DETAIL_RESTRICT value = &v[o];
            std::size_t x = 0;
#if AAF_SIMD_BYTES > 0
            using S = simd<T>;
            for (; x + S::lanes <= w; x += S::lanes)
                S::store(n + x, S::select(S::finite(S::load(value + x)), S::load(n + x), S::splat(nan)));
#endif
            for (; x < w; ++x) n[x] = std::abs(value[x]) <= max_finite ? n[x] : nan;
        }
        if constexpr (ids) copy_row(g.ids, y, &id[o]);
        if constexpr (positions) copy_row(g.positions, y, &px[o], &py[o], &pz[o]);
        if constexpr (plane_coordinates) to_plane_coordinates(&px[o], &py[o], &pz[o], w, basis);
    }

    using cursor = tap_cursor<T>;
    /// Pointers to the element `i` of every array (the lanes' neighbours on one side).
    [[nodiscard]] cursor at(std::size_t i) const noexcept {
        cursor c{&v[i], nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr};
        if constexpr (normals) c.nx = &nx[i], c.ny = &ny[i], c.nz = &nz[i];
        if constexpr (ids) c.id = &id[i];
        if constexpr (positions) c.px = &px[i], c.py = &py[i], c.pz = &pz[i];
        return c;
    }
};

/// Per-lane state of one row of centres (structure of arrays, so that the set-up, the taps and the
/// normalisation vectorise): the kernel radius as T (so that masks have the lanes' width; 0 = no taps),
/// the image-space weight recurrence w_k, m_k, q, the light-plane 1/(2β²) and the two sums.
template <class T>
struct lane_state {
    std::vector<T> beta, pixel_size, full_radius, radius, a, wk, mk, q, sum, wsum, inv_two_beta2, out;

    explicit lane_state(std::size_t w)
        : beta(w), pixel_size(w), full_radius(w), radius(w), a(w), wk(w), mk(w), q(w), sum(w), wsum(w),
          inv_two_beta2(w), out(w) {}
};

/// The vertical image-space pass's per-block lane state (rows × width): radii, sums, and each row's
/// neighbour rows (see filter_pass).
template <class T>
struct block_state {
    std::vector<T> full_radius, radius, sum, wsum;
    std::vector<std::size_t> left, right;
    void fit(std::size_t lanes, std::size_t offsets) {
        if (radius.size() < lanes) full_radius.resize(lanes), radius.resize(lanes), sum.resize(lanes), wsum.resize(lanes);
        if (left.size() < offsets) left.resize(offsets), right.resize(offsets);
    }
};

/// What a pass works in, kept from task to task, from the horizontal to the vertical pass and (in a
/// filter_workspace) from call to call: allocated (and its pages first touched) once, not per task or call.
template <class T>
struct pass_workspace {
    lane_state<T> st;
    row_buffers<T> rows;
    std::vector<unsigned char> lok, rok;  // light plane: the lanes' accepted taps
    std::vector<std::size_t> left, right;  // image space, vectors: the rows' elements of lane 0's neighbours at ∓k
    block_state<T> block;                  // vertical image-space pass, vectors
    std::vector<T> block_inv_two_beta2;    // vertical light-plane pass, vectors: the block's 1/(2β²)

    explicit pass_workspace(std::size_t w) : st(w), lok(filter_lane_block), rok(filter_lane_block) {}
};

/// The workspaces of one call, each lent to one task at a time (as many exist as tasks ever ran at once),
/// taken from and given back to a filter_workspace's spares (`spares` keeps its capacity, so that giving
/// back does not allocate either).
template <class T>
class workspace_pool {
public:
    using spares_type = std::vector<std::unique_ptr<pass_workspace<T>>>;
    workspace_pool(std::size_t width, spares_type& spares) : width_(width), spares_(spares) {
        // A spare made for another width is remade (rare: a frame loop keeps its size).
        for (auto& ws : spares_)
            if (ws->st.beta.size() != width_) ws = std::make_unique<pass_workspace<T>>(width_);
    }

    /// Calls f(workspace) with a free workspace (a new one if none is free).
    template <class F>
    void lend(F&& f) {
        std::unique_ptr<pass_workspace<T>> ws;
        {
            const std::lock_guard lock(mutex_);
            if (!spares_.empty()) ws = std::move(spares_.back()), spares_.pop_back();
        }
        if (!ws) ws = std::make_unique<pass_workspace<T>>(width_);
        f(*ws);
        const std::lock_guard lock(mutex_);
        spares_.push_back(std::move(ws));
    }

private:
    std::size_t width_;
    spares_type& spares_;
    std::mutex mutex_;
};

/// Taps at distances k, k+1, …, k+K−1 on both sides of lanes [0, n) in image space: for each distance,
/// advances the weight recurrence, then adds the −k neighbour and the +k neighbour when accepted. K > 1
/// loads and stores each lane's state once per K distances (the lanes' order of operations is unchanged).
/// Branch-free so that it vectorises; a rejected tap leaves the sums untouched (a blend, not an add of 0,
/// so a −0 sum stays −0 as in the scalar loop).
template <std::size_t K, class T, bool Normals, bool Ids, class Cursor>
void image_taps(std::size_t n, std::size_t k, T cos_threshold, const T* AAF_DETAIL_RESTRICT radius,
                T* AAF_DETAIL_RESTRICT wk, T* AAF_DETAIL_RESTRICT mk, const T* AAF_DETAIL_RESTRICT q,
                T* AAF_DETAIL_RESTRICT sum, T* AAF_DETAIL_RESTRICT wsum, const Cursor& centre,
                const std::array<Cursor, K>& left, const std::array<Cursor, K>& right) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    const T* AAF_DETAIL_RESTRICT cnx = centre.nx;
    const T* AAF_DETAIL_RESTRICT cny = centre.ny;
    const T* AAF_DETAIL_RESTRICT cnz = centre.nz;
    const std::uint32_t* AAF_DETAIL_RESTRICT cid = centre.id;
    for (std::size_t i = 0; i < n; ++i) {
        T w = wk[i], m = mk[i], s = sum[i], ws = wsum[i];
        const T qi = q[i], ri = radius[i];
        // Accepts the neighbour at element i of `c`: finite value, same ID, normal within the threshold.
        const auto accepts = [&](const Cursor& c, T v) {
            // False for ±Inf and NaN; with normals, tap_rows gave such values a NaN normal instead.
            bool ok = Normals || std::abs(v) <= max_finite;
            if constexpr (Ids) ok = ok & (c.id[i] == cid[i]);
            // Same expression as glm::dot(centre, neighbour); `>=` is false for NaN normals, which reject.
            if constexpr (Normals) ok = ok & (cnx[i] * c.nx[i] + cny[i] * c.ny[i] + cnz[i] * c.nz[i] >= cos_threshold);
            return ok;
        };
        for (std::size_t j = 0; j < K; ++j) {
            w = w * m;
            m = m * qi;
            const bool in = static_cast<T>(k + j) <= ri;
            const T l = left[j].v[i], r = right[j].v[i];
            const bool lok = in & accepts(left[j], l);
            const bool rok = in & accepts(right[j], r);
            s = lok ? s + w * l : s;
            ws = lok ? ws + w : ws;
            s = rok ? s + w * r : s;
            ws = rok ? ws + w : ws;
        }
        wk[i] = w;
        mk[i] = m;
        sum[i] = s;
        wsum[i] = ws;
    }
}

#if AAF_SIMD_BYTES > 0
/// Image-space taps of `Groups` vectors of lanes (simd<T>::lanes centres each; group g's centres start at
/// element `centre(g)` of `rows`), over all their distances: each lane's state (sums, weight recurrence,
/// radius, centre guides) stays in registers from k = 1 to the groups' largest radius. `radius[g]` holds
/// the lanes' radii (0: no taps), `m1[g]` their m_1 = exp(−a); `side(k, g)` returns the elements of `rows`
/// where group g's neighbours at −k and +k start (a std::pair). Calls `finish(g, sum, wsum)` per group
/// with the lanes' sums. Each lane performs the arithmetic of image_taps (and of the per-pixel definition) in
/// the same order — w·m, m·q, the −k side, then the +k side, a rejected tap a select, not an add of 0 — so
/// the results are the same bits. Several groups at once give the processor independent dependency chains
/// (one group's sum is a chain of adds through its two sides).
template <std::size_t Groups, class T, class Rows, class Centre, class Side, class Finish>
void image_lane_group_taps(const Rows& rows, Centre&& centre, const typename simd<T>::vec* radius,
                           const typename simd<T>::vec* m1, T cos_threshold, Side&& side, Finish&& finish) noexcept {
    using S = simd<T>;
    using vec = typename S::vec;
    using mask = typename S::mask;
    constexpr std::size_t N = S::lanes;
    constexpr bool normals = Rows::normals, ids = Rows::ids;
    const T* AAF_DETAIL_RESTRICT v = rows.v;
    vec s[Groups], ws[Groups], wk[Groups], mk[Groups], q[Groups], r[Groups];
    [[maybe_unused]] vec cnx[Groups], cny[Groups], cnz[Groups];
    [[maybe_unused]] typename S::id cid[Groups];
    std::int32_t steps = 0;  // the largest radius (whole numbers in [0, 1024]; an integer max vectorises)
    for (std::size_t g = 0; g < Groups; ++g) {
        const std::size_t c = centre(g);
        r[g] = radius[g];
        mk[g] = m1[g];
        q[g] = mk[g] * mk[g];
        s[g] = S::load(v + c);
        ws[g] = S::splat(T(1));
        wk[g] = S::splat(T(1));
        if constexpr (normals) cnx[g] = S::load(&rows.nx[c]), cny[g] = S::load(&rows.ny[c]), cnz[g] = S::load(&rows.nz[c]);
        if constexpr (ids) cid[g] = S::template load<typename S::id>(&rows.id[c]);
        const auto whole = __builtin_convertvector(r[g], mask);
        for (std::size_t l = 0; l < N; ++l) steps = std::max(steps, static_cast<std::int32_t>(whole[l]));
    }
    const vec threshold = S::splat(cos_threshold);
    // The radius test is in `tap`, not shared by the two sides: GCC 12 turns an AVX-512 mask used by two
    // taps into bit-by-bit scalar code (4x slower).
    const auto tap = [&](std::size_t g, std::size_t i, vec distance) {
        const vec value = S::load(v + i);
        mask ok = distance <= r[g];
        // False for ±Inf and NaN; with normals, tap_rows gave such values a NaN normal instead.
        if constexpr (!normals) ok = ok & S::finite(value);
        if constexpr (ids) ok = ok & S::equal(S::template load<typename S::id>(&rows.id[i]), cid[g]);
        // Same expression as glm::dot(centre, neighbour); `>=` is false for NaN normals, which reject.
        if constexpr (normals)
            ok = ok & (cnx[g] * S::load(&rows.nx[i]) + cny[g] * S::load(&rows.ny[i]) + cnz[g] * S::load(&rows.nz[i]) >= threshold);
        s[g] = S::select(ok, s[g] + wk[g] * value, s[g]);
        ws[g] = S::select(ok, ws[g] + wk[g], ws[g]);
    };
    for (std::size_t k = 1; k <= static_cast<std::size_t>(steps); ++k) {
        const vec distance = S::splat(static_cast<T>(k));
        for (std::size_t g = 0; g < Groups; ++g) {
            const auto [l, rr] = side(k, g);
            wk[g] = wk[g] * mk[g];
            mk[g] = mk[g] * q[g];
            tap(g, l, distance);
            tap(g, rr, distance);
        }
    }
    for (std::size_t g = 0; g < Groups; ++g) finish(g, s[g], ws[g]);
}

/// image_lane_group_taps for lanes [x0, x0 + Groups·lanes) of a row whose centres are element `centre_at`
/// of `rows`, with their radii and m_1 in arrays indexed by lane and lane 0's neighbours at −k and +k at
/// elements `left[k]`, `right[k]` of `rows`; writes the sums to `sum`, `wsum` (indexed by lane).
template <std::size_t Groups, class T, class Rows>
void image_lane_groups(std::size_t x0, std::size_t centre_at, const Rows& rows, const std::size_t* AAF_DETAIL_RESTRICT left,
                       const std::size_t* AAF_DETAIL_RESTRICT right, const T* AAF_DETAIL_RESTRICT radius,
                       const T* AAF_DETAIL_RESTRICT m1, T cos_threshold, T* AAF_DETAIL_RESTRICT sum,
                       T* AAF_DETAIL_RESTRICT wsum) noexcept {
    using S = simd<T>;
    constexpr std::size_t N = S::lanes;
    typename S::vec r[Groups], m[Groups];
    for (std::size_t g = 0; g < Groups; ++g) r[g] = S::load(radius + x0 + g * N), m[g] = S::load(m1 + x0 + g * N);
    image_lane_group_taps<Groups, T>(
        rows, [&](std::size_t g) { return centre_at + x0 + g * N; }, r, m, cos_threshold,
        [&](std::size_t k, std::size_t g) {
            return std::pair<std::size_t, std::size_t>(left[k] + x0 + g * N, right[k] + x0 + g * N);
        },
        [&](std::size_t g, typename S::vec s, typename S::vec ws) {
            S::store(sum + x0 + g * N, s), S::store(wsum + x0 + g * N, ws);
        });
}

/// Groups of lanes processed together by image_lane_groups: two independent chains per distance hide the
/// latency of the sums' adds (AVX-512 has the registers for them; AVX2 and SSE spill a few invariants).
inline constexpr std::size_t filter_vector_groups = 2;

/// Image-space taps of every lane of a row of `w` ≥ simd<T>::lanes centres (see image_lane_groups): blocks
/// of filter_vector_groups vectors, then single vectors, the last one ending at lane w − 1 (it may redo
/// lanes of the previous one, which yields the same bits).
template <class T, class Rows>
void image_row_vector(std::size_t w, std::size_t centre_at, const Rows& rows, const std::size_t* left, const std::size_t* right,
                      const T* radius, const T* m1, T cos_threshold, T* sum, T* wsum) noexcept {
    constexpr std::size_t N = simd<T>::lanes, G = filter_vector_groups;
    std::size_t x0 = 0;
    for (; x0 + G * N <= w; x0 += G * N)
        image_lane_groups<G, T>(x0, centre_at, rows, left, right, radius, m1, cos_threshold, sum, wsum);
    for (; x0 < w; x0 += N)
        image_lane_groups<1, T>(std::min(x0, w - N), centre_at, rows, left, right, radius, m1, cos_threshold, sum, wsum);
}
#endif

/// The light-plane weight of a tap, e^(−d²/(2β²)) = 2^(d²·scale), evaluated as exp2_nonpositive (simd_exp.hpp):
/// `scale` = light_plane_scale(1/(2β²)) = −log2(e)/(2β²), once per centre. std::exp per tap was 8–14x the
/// cost of the image-space filter (docs/DEVIATIONS.md F1: within 2 ulp of it). A tap whose exponent d²·scale
/// is NaN (a NaN position) or below exp2_lowest (a weight below 2^−125 ≈ 2.4e−38 in float, next to the
/// centre's 1) is dropped: the vector lanes test light_plane_accepts; the scalar form returns NaN, which
/// its callers reject as a non-finite weight.
template <class T, class V = T>
[[nodiscard]] V light_plane_scale(V inv_two_beta2) noexcept {
    return inv_two_beta2 * T(-1.4426950408889634073599246810018921);  // −log2(e)/(2β²)
}
template <class T, class V>
[[nodiscard]] V light_plane_weight(V exponent2) noexcept {
    if constexpr (!std::is_same_v<V, T>) return exp2_nonpositive<T>(exponent2);  // lanes: the mask drops taps
    else return exponent2 >= exp2_lowest<T> ? exp2_nonpositive<T>(exponent2) : std::numeric_limits<T>::quiet_NaN();
}
/// Whether the lanes' exponents d²·scale are in exp2_nonpositive's domain (false for NaN).
template <class T, class V>
[[nodiscard]] auto light_plane_accepts(V exponent2) noexcept {
    return exponent2 >= exp2_lowest<T>;
}

#if AAF_SIMD_BYTES > 0
/// Light-plane (or, `Tangent`, tangent-plane) taps of `Groups` vectors of lanes (group g's centres start at
/// element `centre(g)` of `rows`) over all their distances, each lane's state in registers (as
/// image_lane_group_taps): `radius[g]` holds the lanes' radii (0: no taps), `scale[g]` their
/// light_plane_scale(1/(2β²)); `side(k, g)` returns the elements of `rows` where group g's neighbours at −k
/// and +k start (a std::pair); `finish(g, sum, wsum)` receives the sums. The distance projected on the plane,
/// the weight light_plane_weight and the masks are vectors. Each lane performs the arithmetic of
/// light_plane_taps (the scalar rule, and the per-pixel definition with the same exp) in the same order —
/// the same glm expression for the distance, the −k side then the +k side, a rejected tap a select — so the
/// results are the same bits.
template <std::size_t Groups, bool Tangent, class T, class Rows, class Centre, class Side, class Finish>
void light_plane_lane_group_taps(const Rows& rows, Centre&& centre, const typename simd<T>::vec* radius,
                                 const typename simd<T>::vec* scale, T cos_threshold,
                                 Side&& side, Finish&& finish) noexcept {
    using S = simd<T>;
    using vec = typename S::vec;
    using mask = typename S::mask;
    constexpr std::size_t N = S::lanes;
    constexpr bool normals = Rows::normals, ids = Rows::ids;
    const T* AAF_DETAIL_RESTRICT v = rows.v;
    vec s[Groups], ws[Groups], r[Groups], a[Groups], cpx[Groups], cpy[Groups];
    [[maybe_unused]] vec cpz[Groups], cnx[Groups], cny[Groups], cnz[Groups];
    [[maybe_unused]] typename S::id cid[Groups];
    std::int32_t steps = 0;  // the largest radius (whole numbers in [0, 1024]; an integer max vectorises)
    std::int32_t common = std::numeric_limits<std::int32_t>::max();  // the smallest: every lane takes its taps
    for (std::size_t g = 0; g < Groups; ++g) {
        const std::size_t c = centre(g);
        r[g] = radius[g];
        a[g] = scale[g];
        s[g] = S::load(v + c);
        ws[g] = S::splat(T(1));
        cpx[g] = S::load(&rows.px[c]), cpy[g] = S::load(&rows.py[c]);
        if constexpr (Tangent) cpz[g] = S::load(&rows.pz[c]);
        if constexpr (normals) cnx[g] = S::load(&rows.nx[c]), cny[g] = S::load(&rows.ny[c]), cnz[g] = S::load(&rows.nz[c]);
        if constexpr (ids) cid[g] = S::template load<typename S::id>(&rows.id[c]);
        const auto whole = __builtin_convertvector(r[g], mask);
        for (std::size_t l = 0; l < N; ++l) {
            steps = std::max(steps, static_cast<std::int32_t>(whole[l]));
            common = std::min(common, static_cast<std::int32_t>(whole[l]));
        }
    }
    common = std::max(common, std::int32_t(0));  // radii are whole numbers in [0, 1024]; kept safe regardless
    const vec threshold = S::splat(cos_threshold);
    // Up to `common` every lane's radius reaches the distance and the test is left out (`Check` false): it
    // and its `and` are 2-3 of the tap's ~30 operations, whose count bounds this loop at x86-64-v3. The test
    // is in `tap`, not shared by the two sides, for the reason given in image_lane_group_taps.
    const auto tap = [&]<bool Check>(std::bool_constant<Check>, std::size_t g, std::size_t i, vec distance) {
        const vec value = S::load(v + i);
        vec d2;
        if constexpr (Tangent) {  // light_plane_distance2: dp = q − p; |dp|² − (dp·n)², clamped below at 0
            const vec dx = S::load(&rows.px[i]) - cpx[g], dy = S::load(&rows.py[i]) - cpy[g], dz = S::load(&rows.pz[i]) - cpz[g];
            d2 = plane_distance2<vec>(dx, dy, dz, cnx[g], cny[g], cnz[g]);
        } else {  // the plane coordinates' differences (tap_rows::plane_coordinates); NaN stays NaN
            d2 = plane_coordinates_distance2<vec>(S::load(&rows.px[i]) - cpx[g], S::load(&rows.py[i]) - cpy[g]);
        }
        const vec e2 = d2 * a[g];
        mask ok = light_plane_accepts<T>(e2);  // false for a NaN position or a negligible weight
        if constexpr (Check) ok = ok & (distance <= r[g]);
        // False for ±Inf and NaN; with normals, tap_rows gave such values a NaN normal instead.
        if constexpr (!normals) ok = ok & S::finite(value);
        if constexpr (ids) ok = ok & S::equal(S::template load<typename S::id>(&rows.id[i]), cid[g]);
        if constexpr (normals)
            ok = ok & (cnx[g] * S::load(&rows.nx[i]) + cny[g] * S::load(&rows.ny[i]) + cnz[g] * S::load(&rows.nz[i]) >= threshold);
        const vec weight = light_plane_weight<T>(e2);
        s[g] = S::select(ok, s[g] + weight * value, s[g]);
        ws[g] = S::select(ok, ws[g] + weight, ws[g]);
    };
    std::size_t k = 1;
    for (; k <= static_cast<std::size_t>(common); ++k) {
        for (std::size_t g = 0; g < Groups; ++g) {
            const auto [l, rr] = side(k, g);
            tap(std::false_type{}, g, l, threshold);
            tap(std::false_type{}, g, rr, threshold);
        }
    }
    for (vec distance = S::splat(static_cast<T>(k)); k <= static_cast<std::size_t>(steps); ++k, distance += T(1)) {
        for (std::size_t g = 0; g < Groups; ++g) {
            const auto [l, rr] = side(k, g);
            tap(std::true_type{}, g, l, distance);
            tap(std::true_type{}, g, rr, distance);
        }
    }
    for (std::size_t g = 0; g < Groups; ++g) finish(g, s[g], ws[g]);
}

/// light_plane_lane_group_taps for lanes [x0, x0 + Groups·lanes) of a row whose centres are element
/// `centre_at` of `rows`, with their radii and 1/(2β²) in arrays indexed by lane and lane 0's neighbours at
/// −k and +k at elements `left[k]`, `right[k]` of `rows`; writes the sums to `sum`, `wsum` (indexed by lane).
template <std::size_t Groups, bool Tangent, class T, class Rows>
void light_plane_lane_groups(std::size_t x0, std::size_t centre_at, const Rows& rows,
                             const std::size_t* AAF_DETAIL_RESTRICT left, const std::size_t* AAF_DETAIL_RESTRICT right,
                             const T* AAF_DETAIL_RESTRICT radius, const T* AAF_DETAIL_RESTRICT inv_two_beta2,
                             T cos_threshold, T* AAF_DETAIL_RESTRICT sum,
                             T* AAF_DETAIL_RESTRICT wsum) noexcept {
    using S = simd<T>;
    constexpr std::size_t N = S::lanes;
    typename S::vec r[Groups], a[Groups];
    for (std::size_t g = 0; g < Groups; ++g)
        r[g] = S::load(radius + x0 + g * N), a[g] = light_plane_scale<T>(S::load(inv_two_beta2 + x0 + g * N));
    light_plane_lane_group_taps<Groups, Tangent, T>(
        rows, [&](std::size_t g) { return centre_at + x0 + g * N; }, r, a, cos_threshold,
        [&](std::size_t k, std::size_t g) {
            return std::pair<std::size_t, std::size_t>(left[k] + x0 + g * N, right[k] + x0 + g * N);
        },
        [&](std::size_t g, typename S::vec s, typename S::vec ws) {
            S::store(sum + x0 + g * N, s), S::store(wsum + x0 + g * N, ws);
        });
}

/// Light-plane taps of every lane of a row of `w` ≥ simd<T>::lanes centres (see light_plane_lane_groups):
/// single vectors, the last one ending at lane w − 1 (it may redo lanes of the previous one: same bits).
template <bool Tangent, class T, class Rows>
void light_plane_row_vector(std::size_t w, std::size_t centre_at, const Rows& rows, const std::size_t* left,
                            const std::size_t* right, const T* radius, const T* inv_two_beta2, T cos_threshold, T* sum,
                            T* wsum) noexcept {
    constexpr std::size_t N = simd<T>::lanes;
    for (std::size_t x0 = 0; x0 < w; x0 += N)
        light_plane_lane_groups<1, Tangent, T>(std::min(x0, w - N), centre_at, rows, left, right, radius, inv_two_beta2,
                                               cos_threshold, sum, wsum);
}
#endif

/// Light-plane taps at distance k: the guide masks vectorise; the distances, the weights and the sums run
/// per lane in the scalar order (−k side, then +k side). (The path of rows narrower than a vector and of
/// builds without vectors; light_plane_lane_groups computes the same bits.) `Tangent`: distances are projected on each
/// centre's own normal (offset_space::tangent_plane) instead of `ln`.
template <class T, bool Normals, bool Ids, bool Tangent = false>
void light_plane_taps(std::size_t n, T k, T cos_threshold, const T* AAF_DETAIL_RESTRICT radius,
                      const T* AAF_DETAIL_RESTRICT inv_two_beta2, T* AAF_DETAIL_RESTRICT sum, T* AAF_DETAIL_RESTRICT wsum,
                      const T* AAF_DETAIL_RESTRICT cnx, const T* AAF_DETAIL_RESTRICT cny, const T* AAF_DETAIL_RESTRICT cnz,
                      const std::uint32_t* AAF_DETAIL_RESTRICT cid, const T* AAF_DETAIL_RESTRICT cpx,
                      const T* AAF_DETAIL_RESTRICT cpy, const T* AAF_DETAIL_RESTRICT cpz,
                      tap_cursor<T> L, tap_cursor<T> R,
                      unsigned char* AAF_DETAIL_RESTRICT lok,
                      unsigned char* AAF_DETAIL_RESTRICT rok) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    for (std::size_t i = 0; i < n; ++i) {
        const bool in = k <= radius[i];
        bool l = in & (std::abs(L.v[i]) <= max_finite);
        bool r = in & (std::abs(R.v[i]) <= max_finite);
        if constexpr (Ids) {
            l = l & (L.id[i] == cid[i]);
            r = r & (R.id[i] == cid[i]);
        }
        if constexpr (Normals) {
            l = l & (cnx[i] * L.nx[i] + cny[i] * L.ny[i] + cnz[i] * L.nz[i] >= cos_threshold);
            r = r & (cnx[i] * R.nx[i] + cny[i] * R.ny[i] + cnz[i] * R.nz[i] >= cos_threshold);
        }
        lok[i] = l;
        rok[i] = r;
    }
    // The distance as the per-pixel definition computes it (plane_distance2, plane_coordinates_distance2:
    // the same expressions as the vector lanes, so that fma contraction treats all alike: the same bits).
    const auto add = [&](std::size_t i, const auto& c) {
        T d2;
        if constexpr (Tangent) {
            const glm::vec<3, T> p{cpx[i], cpy[i], cpz[i]}, q{c.px[i], c.py[i], c.pz[i]};
            d2 = light_plane_distance2<T>(q, p, glm::vec<3, T>{cnx[i], cny[i], cnz[i]});
        } else {  // the rows hold the plane coordinates (tap_rows::plane_coordinates)
            d2 = plane_coordinates_distance2<T>(c.px[i] - cpx[i], c.py[i] - cpy[i]);
        }
        const T weight = light_plane_weight<T>(d2 * light_plane_scale<T>(inv_two_beta2[i]));
        if (!std::isfinite(weight)) return;  // NaN position, or a negligible weight
        sum[i] += weight * c.v[i];
        wsum[i] += weight;
    };
    for (std::size_t i = 0; i < n; ++i) {
        if (lok[i]) add(i, L);
        if (rok[i]) add(i, R);
    }
}

#if AAF_SIMD_BYTES > 0
/// Kernel radii (as T, 0 = copy) of a vector of centres from their β, d and β/d: kernel_radius in lanes
/// (row_radii and the fused row copies of the vector passes, which use β/d again).
template <class T>
[[nodiscard, gnu::always_inline]] inline typename simd<T>::vec kernel_radius_lanes(typename simd<T>::vec b, typename simd<T>::vec d,
                                                                                 typename simd<T>::vec beta_px, T truncation,
                                                                                 T max_radius) noexcept {
    using S = simd<T>;
    using vec = typename S::vec;
    const vec zero = S::splat(T(0));
    const vec t = truncation * beta_px, capped = S::select(t < max_radius, t, S::splat(max_radius));
    const typename S::mask has = (b > zero) & (d > zero) & (beta_px > zero);
    const vec whole = __builtin_convertvector(__builtin_convertvector(S::select(has, capped, zero), typename S::mask), vec);
    return S::select(has, S::select(whole < capped, whole + T(1), whole), zero);
}
#endif

/// Kernel radii (as T, 0 = copy) of row `y`'s centres into `st.full_radius`; returns the row's β and d
/// (in place when packed, else copied to `st.beta`, `st.pixel_size`). Vectorised form of kernel_radius,
/// the same numbers.
template <class T>
std::pair<const T*, const T*> row_radii(lane_state<T>& st, const_image_view<T> beta, const_image_view<T> pixel_size,
                                        const filter_settings<T>& s, std::size_t y) noexcept {
    const std::size_t w = beta.width();
    const T* AAF_DETAIL_RESTRICT bw = row_of(beta, y, st.beta.data());
    const T* AAF_DETAIL_RESTRICT dw = row_of(pixel_size, y, st.pixel_size.data());
    T* AAF_DETAIL_RESTRICT radius = st.full_radius.data();
    const T truncation = s.truncation, max_radius = static_cast<T>(s.max_radius);
    std::size_t x0 = 0;
#if AAF_SIMD_BYTES > 0
    using S = simd<T>;
    for (; x0 + S::lanes <= w; x0 += S::lanes) {  // the loop below, in vectors
        const typename S::vec b = S::load(bw + x0), d = S::load(dw + x0);
        S::store(radius + x0, kernel_radius_lanes<T>(b, d, b / d, truncation, max_radius));
    }
#endif
    for (std::size_t x = x0; x < w; ++x) {
        const T b = bw[x], d = dw[x], beta_px = b / d;
        // min(ceil(t), max_radius) = ceil(min(t, max_radius)) as max_radius is an integer, and that ceil is
        // computed by truncation (std::ceil does not vectorise unless -fno-trapping-math); NaN goes to the cap.
        const T t = truncation * beta_px, capped = t < max_radius ? t : max_radius;
        const bool has = (b > T(0)) & (d > T(0)) & (beta_px > T(0));
        const T whole = static_cast<T>(static_cast<std::int32_t>(has ? capped : T(0)));  // in [0, 1024]
        radius[x] = has ? (whole < capped ? whole + T(1) : whole) : T(0);
    }
    return {bw, dw};
}

/// The lanes' initial state for a row of centres `cv` (and their positions, light plane): a lane with taps
/// has a finite centre (and position) and its kernel radius; the others get radius 0.
template <bool LightPlane, class T>
void setup_lanes(std::size_t w, const T* AAF_DETAIL_RESTRICT cv, const T* AAF_DETAIL_RESTRICT cpx,
                 const T* AAF_DETAIL_RESTRICT cpy, const T* AAF_DETAIL_RESTRICT cpz, const T* AAF_DETAIL_RESTRICT full_radius,
                 const T* AAF_DETAIL_RESTRICT bw, const T* AAF_DETAIL_RESTRICT dw, T* AAF_DETAIL_RESTRICT radius,
                 T* AAF_DETAIL_RESTRICT a, T* AAF_DETAIL_RESTRICT wk, T* AAF_DETAIL_RESTRICT sum,
                 T* AAF_DETAIL_RESTRICT wsum, T* AAF_DETAIL_RESTRICT inv_two_beta2) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    for (std::size_t x = 0; x < w; ++x) {
        const T centre = cv[x];
        bool taps = std::abs(centre) <= max_finite;
        if constexpr (LightPlane) {
            taps = taps & (std::abs(cpx[x] + cpy[x] + cpz[x]) <= max_finite);
            inv_two_beta2[x] = T(1) / (T(2) * bw[x] * bw[x]);
        } else {
            const T beta_px = bw[x] / dw[x];
            a[x] = T(1) / (T(2) * beta_px * beta_px);
        }
        radius[x] = taps ? full_radius[x] : T(0);
        sum[x] = centre;
        wsum[x] = T(1);
        wk[x] = T(1);
    }
}

/// Image space, vector path: each lane's radius (its kernel radius if the centre is finite, else 0) and,
/// unless `a` is null, a = 1/(2(β/d)²) — setup_lanes's numbers without the state that image_lane_groups keeps
/// in registers (sums, weights).
template <class T>
void image_lanes(std::size_t w, const T* AAF_DETAIL_RESTRICT cv, const T* AAF_DETAIL_RESTRICT full_radius,
                 const T* AAF_DETAIL_RESTRICT bw, const T* AAF_DETAIL_RESTRICT dw, T* AAF_DETAIL_RESTRICT radius,
                 T* AAF_DETAIL_RESTRICT a) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    std::size_t x = 0;
#if AAF_SIMD_BYTES > 0
    using S = simd<T>;
    for (; x + S::lanes <= w; x += S::lanes) {
        S::store(radius + x, S::select(S::finite(S::load(cv + x)), S::load(full_radius + x), S::splat(T(0))));
        if (a) {
            const typename S::vec beta_px = S::load(bw + x) / S::load(dw + x);
            S::store(a + x, T(1) / (T(2) * beta_px * beta_px));
        }
    }
#endif
    for (; x < w; ++x) {
        radius[x] = std::abs(cv[x]) <= max_finite ? full_radius[x] : T(0);
        if (a) {
            const T beta_px = bw[x] / dw[x];
            a[x] = T(1) / (T(2) * beta_px * beta_px);
        }
    }
}

/// Whether a centre of the row with a kernel is non-finite (those take the scalar rule; rare).
template <class T>
[[nodiscard]] bool any_non_finite_centre(std::size_t w, const T* AAF_DETAIL_RESTRICT cv,
                                         const T* AAF_DETAIL_RESTRICT full_radius) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    bool any = false;
    std::size_t x = 0;
#if AAF_SIMD_BYTES > 0
    using S = simd<T>;
    typename S::mask m{};
    for (; x + S::lanes <= w; x += S::lanes)
        m |= (S::load(full_radius + x) > S::splat(T(0))) & ~S::finite(S::load(cv + x));
    any = S::any(m);
#endif
    for (; x < w; ++x) any = any | ((full_radius[x] > T(0)) & !(std::abs(cv[x]) <= max_finite));
    return any;
}

/// Σw·v / Σw for lanes with taps (or the centre when the weights sum to 0), the centre for the others.
template <class T>
void normalise_lanes(std::size_t w, const T* AAF_DETAIL_RESTRICT cv, const T* AAF_DETAIL_RESTRICT radius,
                     const T* AAF_DETAIL_RESTRICT sum, const T* AAF_DETAIL_RESTRICT wsum, T* AAF_DETAIL_RESTRICT out) noexcept {
    for (std::size_t x = 0; x < w; ++x) out[x] = ((radius[x] > T(0)) & (wsum[x] > T(0))) ? sum[x] / wsum[x] : cv[x];
}

/// After the horizontal pass filtered row `y` (whose copy in `rows` starts at element `at`): the copy's
/// values become the pass's results (`dst`'s row, for the vertical pass), and with normals, a result that is
/// not finite gets a NaN normal x (so that the normal test alone rejects it, as tap_rows::load does) while a
/// finite result whose input was not finite gets its normal back. `scratch`: w elements.
template <class T, class Rows, class G>
void frame_row_to_results(const Rows& rows, std::size_t at, const_image_view<T> dst, const G& g, std::size_t y,
                          T* scratch) noexcept {
    const std::size_t w = dst.width();
    const T* AAF_DETAIL_RESTRICT out = row_of(dst, y, scratch);
    T* AAF_DETAIL_RESTRICT v = &rows.v[at];
    if constexpr (Rows::normals) {
        constexpr T max_finite = std::numeric_limits<T>::max(), nan = std::numeric_limits<T>::quiet_NaN();
        T* AAF_DETAIL_RESTRICT n = &rows.nx[at];
        bool restore = false;  // a finite result of a non-finite input (rare)
        std::size_t x = 0;
#if AAF_SIMD_BYTES > 0
        using S = simd<T>;
        typename S::mask m{};
        for (; x + S::lanes <= w; x += S::lanes) {
            const typename S::mask in = S::finite(S::load(v + x)), res = S::finite(S::load(out + x));
            m |= res & ~in;
            S::store(n + x, S::select(res, S::load(n + x), S::splat(nan)));
        }
        restore = S::any(m);
#endif
        for (; x < w; ++x) {
            const bool in = std::abs(v[x]) <= max_finite, res = std::abs(out[x]) <= max_finite;
            restore = restore | (res & !in);
            n[x] = res ? n[x] : nan;
        }
        if (restore)
            for (std::size_t i = 0; i < w; ++i)
                if (!(std::abs(v[i]) <= max_finite) && std::abs(out[i]) <= max_finite) n[i] = g.normals(i, y).x;
    }
    std::copy_n(out, w, v);
}

/// Elements of NaN values left and right of each row that the horizontal image-space pass reads.
template <class T>
[[nodiscard]] std::size_t image_row_margin(const filter_settings<T>& s) noexcept {
    return s.max_radius + filter_distances_per_sweep;
}

/// The layout of filter_pass's `frame`: row r's column 0 is element r·stride + margin, both multiples of a
/// 64-byte line, so that the vertical pass's loads (columns in multiples of the vector width) are aligned.
struct frame_layout {
    std::size_t margin, stride;
};
template <class T>
[[nodiscard]] frame_layout image_frame_layout(std::size_t w, const filter_settings<T>& s) noexcept {
    constexpr std::size_t line = 64 / sizeof(T);
    const auto round_up = [](std::size_t n) { return (n + line - 1) / line * line; };
    const std::size_t margin = round_up(image_row_margin(s));
    const std::size_t stride = round_up(w) + 2 * margin;
    // An odd number of lines per row: the vertical pass reads one column of lines through many rows, and
    // an even count maps those rows onto a fraction of the L1 sets (1280 px: 84 lines, a quarter of them).
    return {margin, (stride / line) % 2 ? stride : stride + line};
}

/// Whether the image-space passes keep the frame's structure-of-arrays copies (`frame`, see filter_pass):
/// only for the vector path, and only while the margins cost at most as much memory as the rows.
template <class T>
[[nodiscard]] bool use_image_frame_rows([[maybe_unused]] std::size_t w, [[maybe_unused]] const filter_settings<T>& s) noexcept {
#if AAF_SIMD_BYTES > 0
    return w >= simd<T>::lanes && 2 * image_frame_layout(w, s).margin <= w;
#else
    return false;
#endif
}

/// One 1-D pass over centre rows [y_begin, y_end). For each pixel: the Gaussian of the *centre's* width
/// over the neighbours along `Dir`, skipping neighbours that are non-finite or rejected by a guide,
/// normalised by the weight sum. A centre with β ≤ 0 (or NaN) is copied; a centre whose neighbours are all
/// rejected keeps its value; a non-finite centre gets its accepted finite neighbours' average
/// (non_finite_centre_average, scalar: it is rare).
/// Works in `ws` (reused by the tasks of both passes): the lanes' state for one row and structure-of-arrays
/// copies of the rows within reach (horizontal: the row with max_radius margins; vertical: the task's
/// rows plus its largest radius above and below), about 20–40 bytes per copied pixel.
/// `row_reach[y]` is each row's largest kernel radius: the horizontal pass writes it, the vertical reads it.
/// `decay` (image space, w·h elements): each pixel's m_1 = exp(−a) (0 without a kernel); the horizontal
/// pass writes it, the vertical reads it, so each pixel's std::exp runs once, not once per pass.
/// `frame` (image space, use_image_frame_rows; else null): the structure-of-arrays copies of the whole
/// frame, h + 1 rows of w + 2·margin elements (row h: NaN, for rows outside the image). The horizontal pass
/// copies each row there once (instead of into its own row buffer) and, once the row is filtered, replaces
/// its values by the pass's results and gives the normals of non-finite results a NaN x; the vertical pass
/// reads those rows in place. Without it the vertical pass copies the rows within reach of each block of
/// rows, ~1.8 times every row for β up to 10 px, which was ~30 % of the filter's time (issue 14).
template <pass_direction Dir, offset_space Space, class T, class G>
void filter_pass(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta, const_image_view<T> pixel_size,
                 const G& g, const glm::vec<3, T>& light_normal, const filter_settings<T>& s, std::size_t y_begin,
                 std::size_t y_end, std::size_t* row_reach, T* decay, pass_workspace<T>& ws,
                 row_buffers<T>* frame = nullptr) {
    constexpr bool horizontal = Dir == pass_direction::horizontal;
    constexpr bool light_plane = Space != offset_space::image;  // world offsets: light or tangent plane
    const std::size_t w = src.width(), h = src.height();
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));

    lane_state<T>& st = ws.st;
    tap_rows<T, G, Space> rows(frame ? *frame : ws.rows);
    if constexpr (Space == offset_space::light_plane) rows.basis = tangent_frame<T>(light_normal);
    std::vector<unsigned char>&lok = ws.lok, &rok = ws.rok;  // light plane: the lanes' accepted taps
    const std::size_t margin = image_row_margin(s);  // horizontal: NaN elements left and right of the row
    std::size_t first_row = 0;                      // vertical: image row held in buffer row 0
    std::size_t nan_row = 0;  // vertical: the buffer row of NaN values standing for rows outside the image
    // `frame`: buffer row y holds image row y from element `fl.margin` on; filter_visibility_impl sized it.
    const frame_layout fl = image_frame_layout(w, s);
    if (frame) {
        rows.resize(h + 1, fl.stride, true);  // already that size: no allocation, the same arrays in every task
        nan_row = h;
    } else if constexpr (horizontal) {
        rows.resize(1, w + 2 * margin);
        rows.fill(0, 0, margin);  // `load` writes only [margin, margin + w)
        rows.fill(0, margin + w, w + 2 * margin);
    }
    // The element of `rows` holding column 0 of buffer row r (vertical: `frame` or the block's copies).
    const auto row_start = [&](std::size_t r) { return frame ? r * fl.stride + fl.margin : r * w; };

    // A non-finite centre with a kernel (rare): the scalar rule, after the row's lanes are stored.
    const auto fix_non_finite_centres = [&](std::size_t y, const T* cv, const T* full_radius) {
        if (!any_non_finite_centre(w, cv, full_radius)) return;
        for (std::size_t x = 0; x < w; ++x) {
            const T centre = cv[x];
            if (!(full_radius[x] > T(0)) || std::isfinite(centre)) continue;
            glm::vec<3, T> p{0};
            T inv_two_beta2 = T(0);
            if constexpr (light_plane) {
                p = g.positions(x, y);
                if (!has_position<Space>(p, rows.basis)) continue;  // no position: copied
                inv_two_beta2 = st.inv_two_beta2[x];
            }
            const std::size_t pos = horizontal ? x : y, extent = horizontal ? w : h;
            const T beta_px = beta(x, y) / pixel_size(x, y);
            dst(x, y) = non_finite_centre_average<Dir, Space>(
                src, g, guide_center<T, G>(g, x, y), p, light_normal, x, y, pos, extent,
                static_cast<std::size_t>(full_radius[x]), T(1) / (T(2) * beta_px * beta_px), inv_two_beta2,
                cos_threshold, centre);
        }
    };

    // Blocks of filter_rows_per_task rows, whatever the executor hands out, so that the vertical pass's
    // copy of the rows within reach stays cache-sized (and its buffer is reused).
    for (std::size_t block = y_begin; block < y_end; block += filter_rows_per_task) {
        const std::size_t block_end = std::min(block + filter_rows_per_task, y_end);
        if constexpr (!horizontal) {
            std::size_t reach = 0;  // the largest radius among the block's centres (from the horizontal pass)
            for (std::size_t y = block; y < block_end; ++y) reach = std::max(reach, row_reach[y]);
            const std::size_t r = reach + filter_distances_per_sweep;  // margin for the last group
            if (!frame) {
                first_row = block > r ? block - r : 0;
                const std::size_t last_row = std::min(h, block_end + r);
                nan_row = last_row - first_row;
                rows.resize(nan_row + 1, w);
                rows.fill(nan_row, 0, w);
                for (std::size_t y = first_row; y < last_row; ++y) rows.load(y - first_row, 0, src, g, y);
            }
        }
#if AAF_SIMD_BYTES > 0
        if constexpr (!horizontal && !light_plane) {
            if (w >= simd<T>::lanes) {
                // Vertical, image space, vectors: the lanes of a column group walk all rows of the block before
                // the next group, so that the rows within reach of that group (a few KiB) stay in L1 from one
                // centre row to the next instead of streaming every copied row from L3 for each centre row.
                block_state<T>& B = ws.block;
                const std::size_t n_rows = block_end - block;
                std::size_t reach = 0;
                for (std::size_t y = block; y < block_end; ++y) reach = std::max(reach, row_reach[y]);
                const std::size_t R = reach + 1;
                B.fit(n_rows * w, n_rows * R);
                for (std::size_t y = block; y < block_end; ++y) {
                    const std::size_t i = y - block;
                    const auto C = rows.at(row_start(y - first_row));
                    if (frame) {  // the horizontal pass's radii
                        image_lanes<T>(w, C.v, &frame->radius[y * w], nullptr, nullptr, &B.radius[i * w], nullptr);
                    } else {
                        const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
                        std::copy_n(st.full_radius.data(), w, &B.full_radius[i * w]);
                        setup_lanes<false>(w, C.v, C.px, C.py, C.pz, st.full_radius.data(), bw, dw, &B.radius[i * w],
                                           st.a.data(), st.wk.data(), st.sum.data(), st.wsum.data(), st.inv_two_beta2.data());
                    }
                    for (std::size_t k = 1; k < R; ++k) {
                        B.left[i * R + k] = row_start(k <= y ? y - k - first_row : nan_row);
                        B.right[i * R + k] = row_start(y + k < h ? y + k - first_row : nan_row);
                    }
                }
                constexpr std::size_t N = simd<T>::lanes, G2 = filter_vector_groups;
                const auto column = [&](auto groups, std::size_t x0) {
                    for (std::size_t y = block; y < block_end; ++y) {
                        const std::size_t i = y - block;
                        image_lane_groups<decltype(groups)::value, T>(x0, row_start(y - first_row), rows, &B.left[i * R],
                                                                      &B.right[i * R], &B.radius[i * w], decay + y * w,
                                                                      cos_threshold, &B.sum[i * w], &B.wsum[i * w]);
                    }
                };
                std::size_t x0 = 0;
                for (; x0 + G2 * N <= w; x0 += G2 * N) column(std::integral_constant<std::size_t, G2>{}, x0);
                for (; x0 < w; x0 += N) column(std::integral_constant<std::size_t, 1>{}, std::min(x0, w - N));
                for (std::size_t y = block; y < block_end; ++y) {
                    const std::size_t i = y - block;
                    const auto C = rows.at(row_start(y - first_row));
                    // Straight into a packed destination row, else through st.out.
                    T* out = dst.packed_rows() ? &dst(0, y) : st.out.data();
                    normalise_lanes(w, C.v, &B.radius[i * w], &B.sum[i * w], &B.wsum[i * w], out);
                    if (out == st.out.data()) store_row(out, dst, y);
                    fix_non_finite_centres(y, C.v, frame ? &frame->radius[y * w] : &B.full_radius[i * w]);
                }
                continue;
            }
        }
#endif
#if AAF_SIMD_BYTES > 0
        if constexpr (!horizontal && light_plane) {
            if (w >= simd<T>::lanes) {
                // Vertical, light (or tangent) plane, vectors: as in image space above, a column of lanes walks
                // all rows of the block before the next column, so that the rows within its reach (eight arrays
                // here: value, normal, ID, position) stay in L1 instead of streaming from L3 for each centre row
                // (the per-row order measured 2.4x the image-space pass, mostly waiting on memory).
                block_state<T>& B = ws.block;
                const std::size_t n_rows = block_end - block;
                std::size_t reach = 0;
                for (std::size_t y = block; y < block_end; ++y) reach = std::max(reach, row_reach[y]);
                const std::size_t R = reach + 1;
                B.fit(n_rows * w, n_rows * R);
                if (ws.block_inv_two_beta2.size() < n_rows * w) ws.block_inv_two_beta2.resize(n_rows * w);
                T* inv_two_beta2 = ws.block_inv_two_beta2.data();
                for (std::size_t y = block; y < block_end; ++y) {
                    const std::size_t i = y - block;
                    const auto C = rows.at(row_start(y - first_row));
                    const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
                    std::copy_n(st.full_radius.data(), w, &B.full_radius[i * w]);
                    setup_lanes<true>(w, C.v, C.px, C.py, C.pz, st.full_radius.data(), bw, dw, &B.radius[i * w],
                                      st.a.data(), st.wk.data(), st.sum.data(), st.wsum.data(), &inv_two_beta2[i * w]);
                    for (std::size_t k = 1; k < R; ++k) {
                        B.left[i * R + k] = row_start(k <= y ? y - k - first_row : nan_row);
                        B.right[i * R + k] = row_start(y + k < h ? y + k - first_row : nan_row);
                    }
                }
                constexpr std::size_t N = simd<T>::lanes;
                for (std::size_t x0 = 0; x0 < w; x0 += N)
                    for (std::size_t y = block; y < block_end; ++y) {
                        const std::size_t i = y - block;
                        light_plane_lane_groups<1, Space == offset_space::tangent_plane, T>(
                            std::min(x0, w - N), row_start(y - first_row), rows, &B.left[i * R], &B.right[i * R],
                            &B.radius[i * w], &inv_two_beta2[i * w], cos_threshold, &B.sum[i * w],
                            &B.wsum[i * w]);
                    }
                for (std::size_t y = block; y < block_end; ++y) {
                    const std::size_t i = y - block;
                    const auto C = rows.at(row_start(y - first_row));
                    normalise_lanes(w, C.v, &B.radius[i * w], &B.sum[i * w], &B.wsum[i * w], st.out.data());
                    store_row(st.out.data(), dst, y);
                    std::copy_n(&inv_two_beta2[i * w], w, st.inv_two_beta2.data());  // the scalar rule's 1/(2β²)
                    fix_non_finite_centres(y, C.v, &B.full_radius[i * w]);
                }
                continue;
            }
        }
#endif
        for (std::size_t y = block; y < block_end; ++y) {
            if constexpr (horizontal) {
                if (frame) {  // buffer row y; its margins are written here, once per call
                    rows.fill(y, 0, fl.margin);
                    rows.fill(y, fl.margin + w, fl.stride);
                    rows.load(y, fl.margin, src, g, y);
                } else {
                    rows.load(0, margin, src, g, y);  // the margins keep their NaN values
                }
            }
            // The centres in `rows`.
            const std::size_t centre_at = horizontal ? (frame ? row_start(y) : margin) : row_start(y - first_row);
            const auto C = rows.at(centre_at);
            // Set up the lanes. A lane with taps has a finite centre (and position); the others get radius 0.
            const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
            if constexpr (horizontal) row_reach[y] = largest_radius(st.full_radius.data(), w);
            if (horizontal && frame)  // vectors: the vertical pass reads these radii (image space)
                std::copy_n(st.full_radius.data(), w, &frame->radius[y * w]);
            if (horizontal && frame && !light_plane) {
                image_lanes<T>(w, C.v, st.full_radius.data(), bw, dw, st.radius.data(), st.a.data());
            } else {
                setup_lanes<light_plane>(w, C.v, C.px, C.py, C.pz, st.full_radius.data(), bw, dw, st.radius.data(), st.a.data(),
                                         st.wk.data(), st.sum.data(), st.wsum.data(), st.inv_two_beta2.data());
            }
            bool vector_done = false;
            if constexpr (!light_plane) {
                // w_k = exp(-k² a) by the recurrence w_k = w_{k-1}·m_k, m_k = exp(-(2k-1)a), q = exp(-2a).
                T* AAF_DETAIL_RESTRICT m1 = decay + y * w;
                if constexpr (horizontal)  // every pixel with a kernel (the vertical pass's centres may be finite)
                    exp_negated_as_std(w, st.full_radius.data(), st.a.data(), m1);  // std::exp's bits
#if AAF_SIMD_BYTES > 0
                if (w >= simd<T>::lanes) {
                    const std::size_t reach = largest_radius(st.radius.data(), w);
                    ws.left.resize(reach + 1), ws.right.resize(reach + 1);
                    for (std::size_t k = 1; k <= reach; ++k) {
                        if constexpr (horizontal) {
                            ws.left[k] = centre_at - k, ws.right[k] = centre_at + k;
                        } else {
                            ws.left[k] = row_start(k <= y ? y - k - first_row : nan_row);
                            ws.right[k] = row_start(y + k < h ? y + k - first_row : nan_row);
                        }
                    }
                    image_row_vector<T>(w, centre_at, rows, ws.left.data(), ws.right.data(), st.radius.data(), m1,
                                        cos_threshold, st.sum.data(), st.wsum.data());
                    vector_done = true;
                }
#endif
                if (!vector_done) {
                    T* AAF_DETAIL_RESTRICT mk = st.mk.data();
                    T* AAF_DETAIL_RESTRICT q = st.q.data();
                    for (std::size_t x = 0; x < w; ++x) mk[x] = m1[x], q[x] = m1[x] * m1[x];
                }
            }
#if AAF_SIMD_BYTES > 0
            if constexpr (light_plane) {
                if (w >= simd<T>::lanes) {  // the lanes' neighbours at ∓k: elements of `rows`, as in image space
                    const std::size_t reach = largest_radius(st.radius.data(), w);
                    ws.left.resize(reach + 1), ws.right.resize(reach + 1);
                    for (std::size_t k = 1; k <= reach; ++k) {
                        if constexpr (horizontal) {
                            ws.left[k] = centre_at - k, ws.right[k] = centre_at + k;
                        } else {
                            ws.left[k] = row_start(k <= y ? y - k - first_row : nan_row);
                            ws.right[k] = row_start(y + k < h ? y + k - first_row : nan_row);
                        }
                    }
                    light_plane_row_vector<Space == offset_space::tangent_plane, T>(
                        w, centre_at, rows, ws.left.data(), ws.right.data(), st.radius.data(), st.inv_two_beta2.data(),
                        cos_threshold, st.sum.data(), st.wsum.data());
                    vector_done = true;
                }
            }
#endif
            for (std::size_t x0 = 0; x0 < w && !vector_done; x0 += filter_lane_block) {
                const std::size_t n = std::min(filter_lane_block, w - x0);
                const std::size_t steps = largest_radius(&st.radius[x0], n);
                const auto Cb = rows.at(centre_at + x0);
                using cursor = typename tap_rows<T, G, Space>::cursor;
                const auto side = [&](std::size_t k, bool plus) -> cursor {
                    if constexpr (horizontal) return rows.at(plus ? centre_at + x0 + k : centre_at + x0 - k);
                    if (plus) return rows.at(row_start(y + k < h ? y + k - first_row : nan_row) + x0);
                    return rows.at(row_start(k <= y ? y - k - first_row : nan_row) + x0);
                };
                if constexpr (light_plane) {
                    for (std::size_t k = 1; k <= steps; ++k) {
                        light_plane_taps<T, G::has_normals, G::has_ids, Space == offset_space::tangent_plane>(
                            n, static_cast<T>(k), cos_threshold, &st.radius[x0], &st.inv_two_beta2[x0],
                            &st.sum[x0], &st.wsum[x0], Cb.nx, Cb.ny, Cb.nz, Cb.id, Cb.px, Cb.py, Cb.pz, side(k, false),
                            side(k, true), lok.data(), rok.data());
                    }
                } else {
                    // Distances in groups; a group's last distances may pass `steps`, which every lane's radius
                    // masks (the buffers have that many elements or rows of margin).
                    constexpr std::size_t K = filter_distances_per_sweep;
                    for (std::size_t k = 1; k <= steps; k += K) {
                        std::array<cursor, K> left, right;
                        for (std::size_t j = 0; j < K; ++j) left[j] = side(k + j, false), right[j] = side(k + j, true);
                        image_taps<K, T, G::has_normals, G::has_ids>(n, k, cos_threshold, &st.radius[x0], &st.wk[x0],
                                                                     &st.mk[x0], &st.q[x0], &st.sum[x0], &st.wsum[x0],
                                                                     Cb, left, right);
                    }
                }
            }
            T* out = dst.packed_rows() ? &dst(0, y) : st.out.data();  // straight into a packed destination row
            normalise_lanes(w, C.v, st.radius.data(), st.sum.data(), st.wsum.data(), out);
            if (out == st.out.data()) store_row(out, dst, y);
            fix_non_finite_centres(y, C.v, st.full_radius.data());
            if constexpr (horizontal)
                if (frame) frame_row_to_results(rows, centre_at, const_image_view<T>(dst), g, y, st.out.data());
        }
    }
}

#if AAF_SIMD_BYTES > 0
/// Copies the values `value` of pixels [x, x + lanes) of image row y and their normals and IDs to element
/// c + x of `rows` (the fused row copies: tap_rows::load's numbers, a non-finite value getting a NaN normal
/// x); returns the lanes whose value is finite.
template <class T, class Rows, class G>
[[gnu::always_inline]] inline auto load_lanes(const Rows& rows, std::size_t c, std::size_t x, std::size_t y, const G& g,
                                              typename simd<T>::vec value) noexcept {
    using S = simd<T>;
    using vec = typename S::vec;
    S::store(rows.v + c + x, value);
    const auto finite = S::finite(value);
    if constexpr (Rows::normals) {
        vec nx, ny, nz;
        S::deinterleave3(&g.normals(x, y).x, nx, ny, nz);
        S::store(rows.nx + c + x, S::select(finite, nx, S::splat(std::numeric_limits<T>::quiet_NaN())));
        S::store(rows.ny + c + x, ny), S::store(rows.nz + c + x, nz);
    }
    if constexpr (Rows::ids) std::memcpy(rows.id + c + x, &g.ids(x, y), S::lanes * sizeof(std::uint32_t));
    return finite;
}

/// Whether the horizontal passes on the frame's rows can copy a row in one loop of vectors: the pass's
/// views and the guides it uses have packed rows (GLM's vectors of three packed T for normals, positions).
template <class T, class G>
[[nodiscard]] bool fused_row_copies(const_image_view<T> src, const_image_view<T> beta, const_image_view<T> pixel_size,
                                    const G& g) noexcept {
    bool fused = src.packed_rows() && beta.packed_rows() && pixel_size.packed_rows();
    if constexpr (G::has_normals) fused = fused && g.normals.packed_rows() && sizeof(glm::vec<3, T>) == 3 * sizeof(T);
    if constexpr (G::has_ids) fused = fused && g.ids.packed_rows();
    if constexpr (G::has_positions) fused = fused && g.positions.packed_rows() && sizeof(glm::vec<3, T>) == 3 * sizeof(T);
    return fused;
}

/// Rows per task of the horizontal image-space pass on the frame's rows (image_horizontal_rows): small,
/// so that two or three threads share the rows evenly (a 64-row task was a twelfth of a 720-row frame).
inline constexpr std::size_t image_rows_per_task = 16;

/// The horizontal image-space pass (filter_pass's definition) over rows [y_begin, y_end) into `dst`, on
/// the frame's rows (filter_visibility_impl's `frame`): each row is copied there once (values, normals,
/// IDs; with packed views in one loop with the kernel radii and a = 1/(2(β/d)²), which the vertical pass
/// then reads too), filtered by image_lane_group_taps in place, and its values replaced by the results
/// (frame_row_to_results). `decay` gets each pixel's m_1 = exp(−a) (0 without a kernel). The lanes do
/// image_lane_group_taps's arithmetic and normalise_lanes's selection: the same bits as filter_pass,
/// whatever the split. (Prefetching the next row into L2 while a row's taps run measured no faster.)
template <class T, class G>
void image_horizontal_rows(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta,
                           const_image_view<T> pixel_size, const G& g, const filter_settings<T>& s, row_buffers<T>& frame,
                           T* decay, pass_workspace<T>& ws, std::size_t y_begin, std::size_t y_end) {
    using S = simd<T>;
    using vec = typename S::vec;
    constexpr std::size_t N = S::lanes, G2 = filter_vector_groups;
    constexpr T max_finite = std::numeric_limits<T>::max();
    [[maybe_unused]] constexpr T nan = std::numeric_limits<T>::quiet_NaN();
    const std::size_t w = src.width(), h = src.height();
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
    tap_rows<T, G, offset_space::image> rows(frame);
    const frame_layout fl = image_frame_layout(w, s);
    rows.resize(h + 1, fl.stride, true);  // already that size: no allocation, the same arrays in every task
    lane_state<T>& st = ws.st;
    T* AAF_DETAIL_RESTRICT radius = st.radius.data();
    T* AAF_DETAIL_RESTRICT a = st.a.data();
    // One loop per row when every view is packed, else the general row copies (tap_rows::load, row_radii,
    // image_lanes), which compute the same numbers.
    const bool fused = fused_row_copies(src, beta, pixel_size, g);
    const T truncation = s.truncation, max_radius = static_cast<T>(s.max_radius);
    for (std::size_t y = y_begin; y < y_end; ++y) {
        const std::size_t c = y * fl.stride + fl.margin;
        rows.fill(y, 0, fl.margin);  // the margins, once per call
        rows.fill(y, fl.margin + w, fl.stride);
        T* AAF_DETAIL_RESTRICT full = &frame.radius[y * w];
        if (fused) {
            const T* AAF_DETAIL_RESTRICT vin = &src(0, y);
            const T* AAF_DETAIL_RESTRICT bw = &beta(0, y);
            const T* AAF_DETAIL_RESTRICT dw = &pixel_size(0, y);
            // tap_rows::load (a non-finite value gets a NaN normal x), row_radii and image_lanes, per vector.
            const auto lanes = [&](std::size_t x, vec value) {
                const auto finite = load_lanes<T>(rows, c, x, y, g, value);
                const vec b = S::load(bw + x), d = S::load(dw + x), beta_px = b / d;
                const vec r = kernel_radius_lanes<T>(b, d, beta_px, truncation, max_radius);
                S::store(full + x, r);
                S::store(radius + x, S::select(finite, r, S::splat(T(0))));
                S::store(a + x, T(1) / (T(2) * beta_px * beta_px));
            };
            std::size_t x = 0;
            for (; x + N <= w; x += N) lanes(x, S::load(vin + x));
            if (x < w) lanes(w - N, S::load(vin + w - N));  // the last vector again, ending at w − 1: same numbers
        } else {
            rows.load(y, fl.margin, src, g, y);
            const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
            std::copy_n(st.full_radius.data(), w, full);
            image_lanes<T>(w, rows.v + c, full, bw, dw, radius, a);
        }
        // w_k = exp(-k² a) by the recurrence w_k = w_{k-1}·m_k, m_k = exp(-(2k-1)a), q = exp(-2a).
        T* AAF_DETAIL_RESTRICT m1 = decay + y * w;
        exp_negated_as_std(w, full, a, m1);  // std::exp(−a) per pixel with a kernel, else 0 (its bits)
        T* out = dst.packed_rows() ? &dst(0, y) : st.out.data();  // straight into a packed destination row
        const T* cv = rows.v + c;
        const auto group = [&](auto groups, std::size_t x0) {
            constexpr std::size_t Groups = decltype(groups)::value;
            vec r[Groups], m[Groups];
            for (std::size_t j = 0; j < Groups; ++j) r[j] = S::load(radius + x0 + j * N), m[j] = S::load(m1 + x0 + j * N);
            image_lane_group_taps<Groups, T>(
                rows, [&](std::size_t j) { return c + x0 + j * N; }, r, m, cos_threshold,
                [&](std::size_t k, std::size_t j) {
                    return std::pair<std::size_t, std::size_t>(c + x0 + j * N - k, c + x0 + j * N + k);
                },
                [&](std::size_t j, vec sum, vec wsum) {  // normalise_lanes
                    const std::size_t x = x0 + j * N;
                    const vec zero = S::splat(T(0));
                    S::store(out + x, S::select((r[j] > zero) & (wsum > zero), sum / wsum, S::load(cv + x)));
                });
        };
        std::size_t x0 = 0;
        for (; x0 + G2 * N <= w; x0 += G2 * N) group(std::integral_constant<std::size_t, G2>{}, x0);
        for (; x0 < w; x0 += N) group(std::integral_constant<std::size_t, 1>{}, std::min(x0, w - N));
        if (out == st.out.data()) store_row(out, dst, y);
        // A non-finite centre with a kernel (rare): the scalar rule (filter_pass).
        if (any_non_finite_centre(w, cv, full))
            for (std::size_t x = 0; x < w; ++x) {
                const T centre = cv[x];
                if (!(full[x] > T(0)) || std::abs(centre) <= max_finite) continue;
                const T beta_px = beta(x, y) / pixel_size(x, y);
                dst(x, y) = non_finite_centre_average<pass_direction::horizontal, offset_space::image>(
                    src, g, guide_center<T, G>(g, x, y), glm::vec<3, T>(0), glm::vec<3, T>(0), x, y, x, w,
                    static_cast<std::size_t>(full[x]), T(1) / (T(2) * beta_px * beta_px), T(0), cos_threshold, centre);
            }
        frame_row_to_results(rows, c, const_image_view<T>(dst), g, y, st.out.data());
    }
}
#endif

#if AAF_SIMD_BYTES > 0
/// The horizontal light-plane pass (filter_pass's definition) over rows [y_begin, y_end) into `dst`, on the
/// frame's rows, as image_horizontal_rows does in image space: each row is copied there once (values,
/// normals, IDs, positions; with packed views in one loop with the kernel radii and 1/(2β²)), filtered by
/// light_plane_lane_group_taps in place, and its values replaced by the results (frame_row_to_results).
/// Each row's radii go to `frame.radius`, its largest to `row_reach`, each pixel's 1/(2β²) to
/// `inv_two_beta2` (w·h), for light_plane_vertical_columns. The lanes do setup_lanes's and normalise_lanes's
/// arithmetic: the same bits as filter_pass.
template <class T, class G>
void light_plane_horizontal_rows(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta,
                                 const_image_view<T> pixel_size, const G& g, const glm::vec<3, T>& ln,
                                 const filter_settings<T>& s, row_buffers<T>& frame, T* inv_two_beta2,
                                 std::size_t* row_reach, pass_workspace<T>& ws, std::size_t y_begin, std::size_t y_end) {
    using S = simd<T>;
    using vec = typename S::vec;
    constexpr std::size_t N = S::lanes;
    constexpr T max_finite = std::numeric_limits<T>::max();
    [[maybe_unused]] constexpr T nan = std::numeric_limits<T>::quiet_NaN();
    const std::size_t w = src.width();
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
    tap_rows<T, G, offset_space::light_plane> rows(frame);
    rows.basis = tangent_frame<T>(ln);
    const frame_layout fl = image_frame_layout(w, s);
    rows.resize(src.height() + 1, fl.stride, true);  // already that size: no allocation
    lane_state<T>& st = ws.st;
    T* AAF_DETAIL_RESTRICT radius = st.radius.data();
    const bool fused = fused_row_copies(src, beta, pixel_size, g);  // else tap_rows::load, row_radii, setup_lanes
    const T truncation = s.truncation, max_radius = static_cast<T>(s.max_radius);
    for (std::size_t y = y_begin; y < y_end; ++y) {
        const std::size_t c = y * fl.stride + fl.margin;
        rows.fill(y, 0, fl.margin);  // the margins, once per call
        rows.fill(y, fl.margin + w, fl.stride);
        T* AAF_DETAIL_RESTRICT full = &frame.radius[y * w];
        T* AAF_DETAIL_RESTRICT ib = inv_two_beta2 + y * w;
        if (fused) {
            const T* AAF_DETAIL_RESTRICT vin = &src(0, y);
            const T* AAF_DETAIL_RESTRICT bw = &beta(0, y);
            const T* AAF_DETAIL_RESTRICT dw = &pixel_size(0, y);
            // tap_rows::load (a non-finite value gets a NaN normal x), row_radii and setup_lanes, per vector.
            const auto lanes = [&](std::size_t x, vec value) {
                const auto finite = load_lanes<T>(rows, c, x, y, g, value);
                vec px, py, pz;  // to plane coordinates below, as tap_rows::load does
                S::deinterleave3(&g.positions(x, y).x, px, py, pz);
                S::store(rows.px + c + x, px), S::store(rows.py + c + x, py), S::store(rows.pz + c + x, pz);
                const vec b = S::load(bw + x), d = S::load(dw + x);
                S::store(full + x, kernel_radius_lanes<T>(b, d, b / d, truncation, max_radius));
                S::store(radius + x, S::select(finite, S::splat(T(1)), S::splat(T(0))));  // a finite value
                S::store(ib + x, T(1) / (T(2) * b * b));
            };
            std::size_t x = 0;
            for (; x + N <= w; x += N) lanes(x, S::load(vin + x));
            if (x < w) lanes(w - N, S::load(vin + w - N));  // the last vector again, ending at w − 1: same numbers
            to_plane_coordinates(rows.px + c, rows.py + c, rows.pz + c, w, rows.basis);
            // setup_lanes: taps for a finite value (the 1 above) with a usable position (u + v + 0 finite).
            const T* AAF_DETAIL_RESTRICT pu = rows.px + c;
            const T* AAF_DETAIL_RESTRICT pv = rows.py + c;
            const T* AAF_DETAIL_RESTRICT pz = rows.pz + c;
            for (std::size_t i = 0; i < w; ++i)
                radius[i] = ((radius[i] > T(0)) & (std::abs(pu[i] + pv[i] + pz[i]) <= max_finite)) ? full[i] : T(0);
        } else {
            rows.load(y, fl.margin, src, g, y);
            const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
            std::copy_n(st.full_radius.data(), w, full);
            setup_lanes<true>(w, rows.v + c, rows.px + c, rows.py + c, rows.pz + c, full, bw, dw, radius, st.a.data(),
                              st.wk.data(), st.sum.data(), st.wsum.data(), ib);
        }
        row_reach[y] = largest_radius(full, w);
        T* out = dst.packed_rows() ? &dst(0, y) : st.out.data();  // straight into a packed destination row
        const T* cv = rows.v + c;
        const auto vector = [&](std::size_t x0) {
            const vec r[1] = {S::load(radius + x0)};
            const vec a[1] = {light_plane_scale<T>(S::load(ib + x0))};
            light_plane_lane_group_taps<1, false, T>(
                rows, [&](std::size_t) { return c + x0; }, r, a, cos_threshold,
                [&](std::size_t k, std::size_t) { return std::pair<std::size_t, std::size_t>(c + x0 - k, c + x0 + k); },
                [&](std::size_t, vec sum, vec wsum) {  // normalise_lanes
                    const vec zero = S::splat(T(0));
                    S::store(out + x0, S::select((r[0] > zero) & (wsum > zero), sum / wsum, S::load(cv + x0)));
                });
        };
        for (std::size_t x0 = 0; x0 < w; x0 += N) vector(std::min(x0, w - N));
        if (out == st.out.data()) store_row(out, dst, y);
        // A non-finite centre with a kernel and a position (rare): the scalar rule (filter_pass).
        if (any_non_finite_centre(w, cv, full))
            for (std::size_t x = 0; x < w; ++x) {
                const T centre = cv[x];
                if (!(full[x] > T(0)) || std::abs(centre) <= max_finite) continue;
                const glm::vec<3, T> p = g.positions(x, y);
                if (!has_position<offset_space::light_plane>(p, rows.basis)) continue;  // no position: copied
                const T beta_px = beta(x, y) / pixel_size(x, y);
                dst(x, y) = non_finite_centre_average<pass_direction::horizontal, offset_space::light_plane>(
                    src, g, guide_center<T, G>(g, x, y), p, ln, x, y, x, w, static_cast<std::size_t>(full[x]),
                    T(1) / (T(2) * beta_px * beta_px), ib[x], cos_threshold, centre);
            }
        frame_row_to_results(rows, c, const_image_view<T>(dst), g, y, st.out.data());
    }
}
#endif

#if AAF_SIMD_BYTES > 0
/// Vectors side by side in a column of the vertical image-space pass on the frame's rows, which takes two
/// rows at a time: 2 × 2 vectors (four independent chains) with 32 vector registers (AVX-512), 2 × 1 with
/// 16 (AVX2, SSE), where four spill. Measured on 1280×720 (AMD EPYC, Zen 5; vertical pass, CPU time):
/// AVX-512 1 × 2 vectors 9.0 ms, 2 × 1 8.4–9.0, 2 × 2 7.8–8.4; x86-64-v3 1 × 2 9.4–9.8, 2 × 1 8.9–9.2,
/// 2 × 2 15–16.
inline constexpr std::size_t image_column_vectors = simd_bytes == 64 ? 2 : 1;

/// Columns per task of the vertical image-space pass on the frame's rows (image_vertical_columns): one
/// column of image_column_vectors vectors, whose rows within reach stay in L1 while it walks the image.
template <class T>
[[nodiscard]] constexpr std::size_t image_column_width() noexcept {
    return image_column_vectors * simd<T>::lanes;
}

/// The tasks of the vertical image-space pass on the frame's rows: image_column_width() columns each, the
/// last one up to the right edge (at least simd<T>::lanes columns, as the width is).
template <class T>
[[nodiscard]] std::size_t image_column_tasks(std::size_t w) noexcept {
    return std::max<std::size_t>(1, w / image_column_width<T>());
}

/// The elements of `frame`'s rows (image_frame_layout) that the vertical passes' lanes read as the neighbours
/// at −k and +k of centre row y, for k up to `reach` (light_plane_vertical_columns; image_vertical_columns with
/// 64-byte vectors): `below + y` and `above + (h − 1 − y)` are arrays indexed by k, so that no row builds its
/// own and no tap clamps its rows. Rows outside the image are row h (NaN). `offsets` gets 2·(h + reach + 1)
/// elements (a workspace's: it only grows).
struct column_row_offsets {
    const std::size_t* below;  // below[y + k] = row y + k's first element (row h past the last row)
    const std::size_t* above;  // above[(h − 1 − y) + k] = row y − k's first element (row h above row 0)
};
[[nodiscard]] inline column_row_offsets make_column_row_offsets(std::vector<std::size_t>& offsets, std::size_t h,
                                                                std::size_t reach, frame_layout fl) {
    const std::size_t n = h + reach + 1;
    if (offsets.size() < 2 * n) offsets.resize(2 * n);
    const auto start = [&](std::size_t r) { return (r < h ? r : h) * fl.stride + fl.margin; };
    for (std::size_t j = 0; j < n; ++j) {
        offsets[j] = start(j);                                   // row j
        offsets[n + j] = j < h ? start(h - 1 - j) : start(h);  // row h − 1 − j
    }
    return {offsets.data(), offsets.data() + n};
}

/// The vertical image-space pass (filter_pass's definition) over the columns of tasks [task_begin,
/// task_end) (image_column_tasks), every row, reading the rows the horizontal pass left in `frame` (values
/// = its results, radii, normals, IDs; filter_visibility_impl) in place. Each column of lanes walks the
/// whole image top to bottom, so that the rows within its reach are read from memory once and stay in L1
/// from one centre row to the next (64-row blocks of all columns re-read ~0.75 of every block from L2/L3 for
/// the rows above and below them, and their taps took twice the horizontal pass's time). The lanes do
/// image_lane_group_taps's arithmetic and normalise_lanes's selection: the same bits, whatever the split.
template <class T, class G>
void image_vertical_columns(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta,
                            const_image_view<T> pixel_size, const G& g, const filter_settings<T>& s,
                            row_buffers<T>& frame, const T* decay, column_row_offsets offsets, std::size_t task_begin,
                            std::size_t task_end) {
    using S = simd<T>;
    using vec = typename S::vec;
    constexpr std::size_t N = S::lanes, C = image_column_vectors, width = image_column_width<T>();
    const std::size_t w = src.width(), h = src.height(), tasks = image_column_tasks<T>(w);
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
    tap_rows<T, G, offset_space::image> rows(frame);
    const frame_layout fl = image_frame_layout(w, s);
    rows.resize(h + 1, fl.stride, true);  // already that size: no allocation, the same arrays in every task
    const auto row_start = [&](std::size_t r) { return r * fl.stride + fl.margin; };
    const T* full_radius = frame.radius.data();
    const bool packed = dst.packed_rows();
    // The rows that enter the reach next: the walk's row stride defeats the hardware prefetchers.
    const std::size_t ahead = std::min<std::size_t>(s.max_radius, 64) + 2;
    // Rows y0 … y0 + Rows2 − 1 of the column of `Cols` vectors from lane x0: Cols·Rows2 independent chains
    // (group j: row y0 + j / Cols, lanes from x0 + (j % Cols)·N). Consecutive rows share nearly all their
    // reach, so a second row adds chains without widening the columns held in L1.
    const auto step = [&](auto cols, auto rows2, std::size_t x0, std::size_t y0) {
        constexpr std::size_t Cols = decltype(cols)::value, Rows2 = decltype(rows2)::value, Groups = Cols * Rows2;
        for (std::size_t dy = 0; dy < Rows2 && y0 + ahead + dy < h; ++dy) {
            const std::size_t p = row_start(y0 + ahead + dy) + x0;
            for (std::size_t b = 0; b < Cols * N * sizeof(T); b += 64) {
                __builtin_prefetch(reinterpret_cast<const char*>(rows.v + p) + b);
                if constexpr (G::has_normals) {
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.nx + p) + b);
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.ny + p) + b);
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.nz + p) + b);
                }
                if constexpr (G::has_ids) __builtin_prefetch(reinterpret_cast<const char*>(rows.id + p) + b);
            }
        }
        // The centres' radii and m_1, w·h arrays walked down the column too (their loads were the stalls of
        // this loop: AVX-512, Zen 5: CPU time 7.2 -> 6.9 ms per frame; AVX2, Zen 3: the whole filter 49.8 ->
        // 39.4 ms, docs/BENCHMARKS.md). With one AVX2 vector (half a line) per row a Zen 5 run at x86-64-v3
        // had measured them slower (8.4 -> 9.1 ms, vertical pass); on an AVX2-only CPU they are the largest
        // single gain measured.
        constexpr std::size_t centre_ahead = 8;  // rows; 4 and 16 measured slower or no faster (AVX-512)
        for (std::size_t dy = 0; dy < Rows2 && y0 + centre_ahead + dy < h; ++dy) {
            const std::size_t at = (y0 + centre_ahead + dy) * w + x0;
            for (std::size_t b = 0; b < Cols * N * sizeof(T); b += 64) {
                __builtin_prefetch(reinterpret_cast<const char*>(decay + at) + b);
                __builtin_prefetch(reinterpret_cast<const char*>(full_radius + at) + b);
            }
        }
        const auto row_of = [&](std::size_t j) { return y0 + j / Cols; };
        const auto lane_of = [&](std::size_t j) { return x0 + (j % Cols) * N; };
        vec r[Groups], m[Groups];
        for (std::size_t j = 0; j < Groups; ++j) {  // image_lanes: no taps for a non-finite centre
            const std::size_t y = row_of(j), x = lane_of(j), at = y * w + x;
            r[j] = S::select(S::finite(S::load(rows.v + row_start(y) + x)), S::load(full_radius + at), S::splat(T(0)));
            m[j] = S::load(decay + at);
        }
        image_lane_group_taps<Groups, T>(
            rows, [&](std::size_t j) { return row_start(row_of(j)) + lane_of(j); }, r, m, cos_threshold,
            [&](std::size_t k, std::size_t j) {
                const std::size_t y = row_of(j), x = lane_of(j);
                // The rows from the offsets' tables with 64-byte vectors (AVX-512: four groups in 32 registers;
                // 14.0-14.3 -> 13.2-13.6 ms per 1280x720 frame, 1 thread, Zen 5); with narrower ones GCC 12 then
                // moved the weight recurrence to the stack (x86-64-v3: 19.0 -> 21.1 ms), so they clamp here.
                using rows_pair = std::pair<std::size_t, std::size_t>;
                if constexpr (image_column_vectors == 2)
                    return rows_pair(offsets.above[(h - 1 - y) + k] + x, offsets.below[y + k] + x);
                else
                    return rows_pair(row_start(k <= y ? y - k : h) + x, row_start(y + k < h ? y + k : h) + x);
            },
            [&](std::size_t j, vec sum, vec wsum) {
                const std::size_t y = row_of(j), x = lane_of(j), at = y * w + x;
                const vec cv = S::load(rows.v + row_start(y) + x), zero = S::splat(T(0));
                const vec out = S::select((r[j] > zero) & (wsum > zero), sum / wsum, cv);  // normalise_lanes
                if (packed) S::store(&dst(x, y), out);
                else for (std::size_t l = 0; l < N; ++l) dst(x + l, y) = out[l];
                // A non-finite centre with a kernel (rare): the scalar rule (filter_pass).
                const vec full = S::load(full_radius + at);
                if (!S::any((full > zero) & ~S::finite(cv))) return;
                for (std::size_t l = 0; l < N; ++l) {
                    if (!(full[l] > T(0)) || std::isfinite(cv[l])) continue;
                    const T beta_px = beta(x + l, y) / pixel_size(x + l, y);
                    dst(x + l, y) = non_finite_centre_average<pass_direction::vertical, offset_space::image>(
                        src, g, guide_center<T, G>(g, x + l, y), glm::vec<3, T>(0), glm::vec<3, T>(0), x + l, y, y, h,
                        static_cast<std::size_t>(full[l]), T(1) / (T(2) * beta_px * beta_px), T(0), cos_threshold, cv[l]);
                }
            });
    };
    using one = std::integral_constant<std::size_t, 1>;
    using two = std::integral_constant<std::size_t, 2>;
    const auto column = [&](auto cols, std::size_t x0) {
        std::size_t y = 0;
        for (; y + 2 <= h; y += 2) step(cols, two{}, x0, y);
        if (y < h) step(cols, one{}, x0, y);
    };
    for (std::size_t task = task_begin; task < task_end; ++task) {
        const std::size_t x_begin = task * width, x_end = task + 1 == tasks ? w : x_begin + width;
        std::size_t x0 = x_begin;
        for (; x0 + C * N <= x_end; x0 += C * N) column(std::integral_constant<std::size_t, C>{}, x0);
        for (; x0 < x_end; x0 += N) column(one{}, std::min(x0, x_end - N));
    }
}
#endif

#if AAF_SIMD_BYTES > 0
/// The vertical light-plane pass (filter_pass's definition) over the columns of tasks [task_begin, task_end)
/// (image_column_tasks), every row, reading in place the rows the horizontal pass left in `frame` (values =
/// its results, radii, normals, IDs, positions) and each pixel's 1/(2β²) in `inv_two_beta2` (w·h). As in
/// image_vertical_columns, each column of lanes walks the whole image top to bottom, so that the rows within
/// its reach stay in L1 from one centre row to the next, and the rows entering the reach are prefetched
/// (the walk's row stride defeats the hardware prefetchers: in 64-row blocks of every column this pass
/// spent a third of its time waiting on those loads, docs/BENCHMARKS.md). One vector per column: two
/// groups of light-plane lanes spill on AVX-512. The lanes do light_plane_lane_group_taps's arithmetic,
/// setup_lanes's radius rule and normalise_lanes's selection: the same bits as filter_pass.
template <class T, class G>
void light_plane_vertical_columns(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta,
                                  const_image_view<T> pixel_size, const G& g, const glm::vec<3, T>& ln, const filter_settings<T>& s, row_buffers<T>& frame,
                                  const T* inv_two_beta2, column_row_offsets offsets, std::size_t task_begin,
                                  std::size_t task_end) {
    using S = simd<T>;
    using vec = typename S::vec;
    constexpr std::size_t N = S::lanes, width = image_column_width<T>();
    const std::size_t w = src.width(), h = src.height(), tasks = image_column_tasks<T>(w);
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
    tap_rows<T, G, offset_space::light_plane> rows(frame);
    rows.basis = tangent_frame<T>(ln);  // the scalar rule's has_position
    const frame_layout fl = image_frame_layout(w, s);
    rows.resize(h + 1, fl.stride, true);  // already that size: no allocation, the same arrays in every task
    const auto row_start = [&](std::size_t r) { return r * fl.stride + fl.margin; };
    const T* full_radius = frame.radius.data();
    const bool packed = dst.packed_rows();
    const std::size_t ahead = std::min<std::size_t>(s.max_radius, 64) + 2;  // as image_vertical_columns
    constexpr std::size_t centre_ahead = 8;
    const auto step = [&](std::size_t x0, std::size_t y) {
        if (y + ahead < h) {
            const std::size_t p = row_start(y + ahead) + x0;
            for (std::size_t b = 0; b < N * sizeof(T); b += 64) {
                __builtin_prefetch(reinterpret_cast<const char*>(rows.v + p) + b);
                if constexpr (G::has_normals) {
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.nx + p) + b);
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.ny + p) + b);
                    __builtin_prefetch(reinterpret_cast<const char*>(rows.nz + p) + b);
                }
                if constexpr (G::has_ids) __builtin_prefetch(reinterpret_cast<const char*>(rows.id + p) + b);
                __builtin_prefetch(reinterpret_cast<const char*>(rows.px + p) + b);
                __builtin_prefetch(reinterpret_cast<const char*>(rows.py + p) + b);
            }
        }
        if (y + centre_ahead < h) {
            const std::size_t at = (y + centre_ahead) * w + x0;
            for (std::size_t b = 0; b < N * sizeof(T); b += 64) {
                __builtin_prefetch(reinterpret_cast<const char*>(inv_two_beta2 + at) + b);
                __builtin_prefetch(reinterpret_cast<const char*>(full_radius + at) + b);
            }
        }
        const std::size_t c = row_start(y) + x0, at = y * w + x0;
        const vec cv = S::load(rows.v + c), zero = S::splat(T(0)), full = S::load(full_radius + at);
        // setup_lanes: taps for a finite centre with a finite position (the sum, as the scalar rule tests it).
        const auto taps = S::finite(cv) & S::finite(S::load(rows.px + c) + S::load(rows.py + c));  // u + v (+ 0)
        const vec r[1] = {S::select(taps, full, zero)};
        const vec a[1] = {light_plane_scale<T>(S::load(inv_two_beta2 + at))};
        const std::size_t* below = offsets.below + y;
        const std::size_t* above = offsets.above + (h - 1 - y);
        light_plane_lane_group_taps<1, false, T>(
            rows, [&](std::size_t) { return c; }, r, a, cos_threshold,
            [&](std::size_t k, std::size_t) { return std::pair<std::size_t, std::size_t>(above[k] + x0, below[k] + x0); },
            [&](std::size_t, vec sum, vec wsum) {
                const vec out = S::select((r[0] > zero) & (wsum > zero), sum / wsum, cv);  // normalise_lanes
                if (packed) S::store(&dst(x0, y), out);
                else for (std::size_t l = 0; l < N; ++l) dst(x0 + l, y) = out[l];
                // A non-finite centre with a kernel and a position (rare): the scalar rule (filter_pass).
                if (!S::any((full > zero) & ~S::finite(cv))) return;
                for (std::size_t l = 0; l < N; ++l) {
                    const std::size_t x = x0 + l;
                    if (!(full[l] > T(0)) || std::isfinite(cv[l])) continue;
                    const glm::vec<3, T> p = g.positions(x, y);
                    if (!has_position<offset_space::light_plane>(p, rows.basis)) continue;  // no position: copied
                    const T beta_px = beta(x, y) / pixel_size(x, y);
                    dst(x, y) = non_finite_centre_average<pass_direction::vertical, offset_space::light_plane>(
                        src, g, guide_center<T, G>(g, x, y), p, ln, x, y, y, h, static_cast<std::size_t>(full[l]),
                        T(1) / (T(2) * beta_px * beta_px), inv_two_beta2[y * w + x], cos_threshold, cv[l]);
                }
            });
    };
    for (std::size_t task = task_begin; task < task_end; ++task) {
        const std::size_t x_begin = task * width, x_end = task + 1 == tasks ? w : x_begin + width;
        for (std::size_t x0 = x_begin; x0 < x_end; x0 += N)
            for (std::size_t y = 0; y < h; ++y) step(std::min(x0, x_end - N), y);
    }
}
#endif

/// Per-axis footprints (filter_visibility_axes), between the passes of rows [y_begin, y_end): the vertical
/// pass's own kernel radii from β and its footprint `pixel_size` (row_radii, the horizontal pass's rule) —
/// each row's reach and, in image space, each pixel's m_1 = exp(−a) in `decay` and its radius in
/// `frame_radius` (either may be null) — written where the vertical pass reads the horizontal pass's, so
/// the vertical pass runs unchanged (and the horizontal pass's are no longer needed then).
template <class T>
void vertical_pass_radii(const_image_view<T> beta, const_image_view<T> pixel_size, const filter_settings<T>& s,
                         std::size_t y_begin, std::size_t y_end, std::size_t* row_reach, T* decay, T* frame_radius,
                         lane_state<T>& st) noexcept {
    const std::size_t w = beta.width();
    for (std::size_t y = y_begin; y < y_end; ++y) {
        const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
        const T* AAF_DETAIL_RESTRICT full = st.full_radius.data();
        row_reach[y] = largest_radius(full, w);
        if (frame_radius) std::copy_n(full, w, frame_radius + y * w);
        if (decay) {  // a = 1/(2(β/d)²) and m_1 as image_lanes and the horizontal pass compute them
            T* AAF_DETAIL_RESTRICT a = st.a.data();
            for (std::size_t x = 0; x < w; ++x) {
                const T beta_px = bw[x] / dw[x];
                a[x] = T(1) / (T(2) * beta_px * beta_px);
            }
            exp_negated_as_std(w, full, a, decay + y * w);  // std::exp(−a)'s bits, in vectors where it can
        }
    }
}

#undef AAF_DETAIL_RESTRICT

}  // namespace detail

/// Working memory of filter_visibility, kept between calls so that a frame loop allocates nothing per
/// call: each pixel's Gaussian decay (image space, one T per pixel), each row's reach, and one set of lane
/// state and row copies per concurrent task (about 20–40 bytes per copied pixel for 64 rows and the rows
/// within reach). On the vector path (width ≥ one vector, max_radius + 2 ≤ about half the width) the rows
/// are copied once per frame instead: the values, radii and used guides of every pixel (2 T, + 3 T with
/// normals, + 4 bytes with IDs, + 3 T with positions on the light plane per pixel; 24 bytes in
/// float with normals and IDs, on rows padded by 2·32 elements). It grows to the largest frame and task count it has served and is independent of
/// the guides and offset space. Not thread-safe: one call at a time per workspace. Its contents are internal.
template <class T>
struct filter_workspace {
    std::vector<T> decay;
    std::vector<std::size_t> row_reach;
    typename detail::workspace_pool<T>::spares_type passes;
    detail::row_buffers<T> frame;  // image space: the frame's rows for both passes (filter_pass's `frame`)
    std::vector<std::size_t> column_rows;  // the vertical passes' neighbour rows (column_row_offsets)
};

namespace detail {

/// filter_visibility's work, compiled once per pixel type and guides whatever the caller's executor
/// (executor_ref); the compiled mode instantiates it for the common guides (AAF_EXTERN_TEMPLATES).
/// `pixel_size_vertical` (filter_visibility_axes; empty: `pixel_size`) is the vertical pass's footprint.
template <class T, class G>
void filter_visibility_impl(const_image_view<T> visibility, const_image_view<T> filter_width,
                            const_image_view<T> pixel_size, const_image_view<T> pixel_size_vertical, image_view<T> output,
                            image_view<T> scratch, filter_workspace<T>& workspace, const G& g, const filter_settings<T>& s,
                            const glm::vec<3, T>& light_normal, executor_ref exec) {
    const bool per_axis = !pixel_size_vertical.empty();
    const char* fn = per_axis ? "filter_visibility_axes" : "filter_visibility";
    require_nonempty(fn, "visibility", visibility);
    const std::size_t w = visibility.width(), h = visibility.height();
    require_size(fn, "filter_width", filter_width, w, h);
    require_size(fn, per_axis ? "pixel_size_horizontal" : "pixel_size", pixel_size, w, h);
    if (per_axis) require_size(fn, "pixel_size_vertical", pixel_size_vertical, w, h);
    const const_image_view<T> pixel_size_v = per_axis ? pixel_size_vertical : pixel_size;
    require_size(fn, "output", output, w, h);
    require_size(fn, "scratch", scratch, w, h);
    require_guides(fn, g, w, h);
    validate(s, fn);
    if (output.bytes() == visibility.bytes() || output.bytes() == scratch.bytes() ||
        scratch.bytes() == visibility.bytes())
        throw_invalid(fn, "`output`, `scratch` and `visibility` must be distinct buffers");
    // Tasks are blocks of rows; every pixel's result is independent of how they are split.
    const std::size_t tasks = (h + filter_rows_per_task - 1) / filter_rows_per_task;
    const auto row = [h](std::size_t task) { return std::min(task * filter_rows_per_task, h); };
    // Each row's largest kernel radius, from the horizontal pass. Not cleared: the horizontal pass writes
    // every element (and, in image space, every element of `decay`) before the vertical pass reads it.
    if (workspace.row_reach.size() < h) workspace.row_reach.resize(h);
    std::size_t* row_reach = workspace.row_reach.data();
    workspace_pool<T> pool(w, workspace.passes);
    // Per-axis footprints: after the horizontal pass, the vertical pass's own radii (vertical_pass_radii).
    const auto vertical_radii = [&](T* decay, T* frame_radius) {
        if (!per_axis) return;
        exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
            pool.lend([&](auto& ws) { vertical_pass_radii<T>(filter_width, pixel_size_v, s, row(b), row(e), row_reach, decay, frame_radius, ws.st); });
        });
    };
    if (s.space == offset_space::tangent_plane) {
        if constexpr (!G::has_positions || !G::has_normals) {
            throw_invalid(fn, "`settings.space` is tangent_plane but `guides.positions` or `guides.normals` is absent");
        } else {
            constexpr auto space = offset_space::tangent_plane;
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { filter_pass<pass_direction::horizontal, space, T>(visibility, scratch, filter_width, pixel_size, g, light_normal, s, row(b), row(e), row_reach, static_cast<T*>(nullptr), ws); });
            });
            vertical_radii(nullptr, nullptr);
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { filter_pass<pass_direction::vertical, space, T>(scratch, output, filter_width, pixel_size_v, g, light_normal, s, row(b), row(e), row_reach, static_cast<T*>(nullptr), ws); });
            });
            return;
        }
    }
    if (s.space == offset_space::light_plane) {
        if constexpr (!G::has_positions) {
            throw_invalid(fn, "`settings.space` is light_plane but `guides.positions` is absent");
        } else {
            const T len = glm::length(light_normal);
            if (!(len > T(0)) || !std::isfinite(len)) throw_invalid(fn, "`light_normal` must be a finite non-zero vector");
            const glm::vec<3, T> n = light_normal / len;
            // As in image space below: the frame's rows copied once, by the horizontal pass, for both passes
            // (the vertical pass copied the rows within reach of each block again: ~20 % of its time).
            row_buffers<T>* frame = nullptr;
            if (use_image_frame_rows(w, s)) {
                tap_rows<T, G, offset_space::light_plane> rows(workspace.frame);
                const std::size_t stride = image_frame_layout(w, s).stride;
                rows.resize(h + 1, stride, true);
                rows.fill(h, 0, stride);
                if (workspace.frame.radius.size() < w * h) workspace.frame.radius.resize(w * h);
                frame = &workspace.frame;
            }
#if AAF_SIMD_BYTES > 0
            if (frame) {  // rows, then columns of lanes walking the whole image (light_plane_vertical_columns)
                if (workspace.decay.size() < w * h) workspace.decay.resize(w * h);
                T* inv_two_beta2 = workspace.decay.data();  // each pixel's 1/(2β²), from the horizontal pass
                const std::size_t row_tasks = (h + image_rows_per_task - 1) / image_rows_per_task;
                exec.parallel_for(row_tasks, [&](std::size_t b, std::size_t e) {
                    pool.lend([&](auto& ws) {
                        light_plane_horizontal_rows<T>(visibility, scratch, filter_width, pixel_size, g, n, s, *frame,
                                                       inv_two_beta2, row_reach, ws, b * image_rows_per_task,
                                                       std::min(h, e * image_rows_per_task));
                    });
                });
                vertical_radii(nullptr, frame->radius.data());
                const std::size_t reach = *std::max_element(row_reach, row_reach + h);
                const column_row_offsets offsets = make_column_row_offsets(workspace.column_rows, h, reach, image_frame_layout(w, s));
                exec.parallel_for(image_column_tasks<T>(w), [&](std::size_t b, std::size_t e) {
                    light_plane_vertical_columns<T>(scratch, output, filter_width, pixel_size_v, g, n, s, *frame, inv_two_beta2, offsets, b, e);
                });
                return;
            }
#endif
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { filter_pass<pass_direction::horizontal, offset_space::light_plane, T>(visibility, scratch, filter_width, pixel_size, g, n, s, row(b), row(e), row_reach, static_cast<T*>(nullptr), ws, frame); });
            });
            vertical_radii(nullptr, nullptr);
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { filter_pass<pass_direction::vertical, offset_space::light_plane, T>(scratch, output, filter_width, pixel_size_v, g, n, s, row(b), row(e), row_reach, static_cast<T*>(nullptr), ws, frame); });
            });
            return;
        }
    }
    if (workspace.decay.size() < w * h) workspace.decay.resize(w * h);
    T* decay = workspace.decay.data();
    // Image space reads no positions: the passes get the guides without them, so that callers with and
    // without positions (render_frame's light-plane and image-space branches) share one compiled pass.
    const guides<decltype(G::normals), decltype(G::ids), no_guide> gi{g.normals, g.ids, {}};
    row_buffers<T>* frame = nullptr;
    if (use_image_frame_rows(w, s)) {  // sized here, before the tasks share it; row h: NaN (outside the image)
        tap_rows<T, decltype(gi), offset_space::image> rows(workspace.frame);
        const std::size_t stride = image_frame_layout(w, s).stride;
        rows.resize(h + 1, stride, true);
        rows.fill(h, 0, stride);
        if (workspace.frame.radius.size() < w * h) workspace.frame.radius.resize(w * h);
        frame = &workspace.frame;
    }
#if AAF_SIMD_BYTES > 0
    if (frame) {  // rows in small tasks (image_horizontal_rows), then columns of lanes walking the whole image
        const std::size_t row_tasks = (h + image_rows_per_task - 1) / image_rows_per_task;
        exec.parallel_for(row_tasks, [&](std::size_t b, std::size_t e) {
            pool.lend([&](auto& ws) {
                image_horizontal_rows<T>(visibility, scratch, filter_width, pixel_size, gi, s, *frame, decay, ws,
                                         b * image_rows_per_task, std::min(h, e * image_rows_per_task));
            });
        });
        vertical_radii(decay, frame->radius.data());
        // The neighbour rows' tables (image_vertical_columns reads them with 64-byte vectors). Every radius is at
        // most max_radius (kernel_radius_lanes caps it), which bounds their reach (this path keeps no row_reach).
        column_row_offsets offsets{};
        if constexpr (image_column_vectors == 2)
            offsets = make_column_row_offsets(workspace.column_rows, h, s.max_radius, image_frame_layout(w, s));
        exec.parallel_for(image_column_tasks<T>(w), [&](std::size_t b, std::size_t e) {
            image_vertical_columns<T>(scratch, output, filter_width, pixel_size_v, gi, s, *frame, decay, offsets, b, e);
        });
        return;
    }
#endif
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        pool.lend([&](auto& ws) { filter_pass<pass_direction::horizontal, offset_space::image, T>(visibility, scratch, filter_width, pixel_size, gi, light_normal, s, row(b), row(e), row_reach, decay, ws, frame); });
    });
    vertical_radii(decay, frame ? frame->radius.data() : nullptr);
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        pool.lend([&](auto& ws) { filter_pass<pass_direction::vertical, offset_space::image, T>(scratch, output, filter_width, pixel_size_v, gi, light_normal, s, row(b), row(e), row_reach, decay, ws, frame); });
    });
}

}  // namespace detail

/// Filters `visibility` into `output` with the separable guided Gaussian: a horizontal pass into
/// `scratch`, then a vertical pass into `output`, each with the centre pixel's width (as the authors).
///
/// * `filter_width` β is per pixel in world units (formulas.hpp); β ≤ 0 or NaN = leave that pixel as is.
/// * `pixel_size` d is each pixel's projected footprint (world units); image-space offsets use β/d pixels.
/// * Offsets in `offset_space::light_plane` need `guides.positions` and use distances projected on the
///   plane of `light_normal`, from each pixel's coordinates in that plane (docs/DEVIATIONS.md F3: rounded
///   at the scale of the positions); the window is still sized by β/d. `offset_space::tangent_plane` needs
///   `guides.positions` and `guides.normals` (unit) and projects on each centre's own tangent plane.
/// * Non-finite visibility never spreads: such neighbours are skipped; a non-finite centre takes its
///   valid neighbours' average (or stays as it was if it has none).
/// * `output` may alias neither `visibility` nor `scratch`. All views must have the same size.
/// * Working memory comes from `workspace` (filter_workspace): once it has served a frame of this size
///   with as many threads, the call allocates nothing. (The overloads without it make one per call.)
/// Throws aaf::invalid_argument (before touching `output`) on mismatched sizes or invalid settings.
/// T is deduced from `output` only, so mutable views and `image<T>`s convert to the read-only inputs.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output,
                       std::type_identity_t<image_view<T>> scratch, filter_workspace<T>& workspace, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    detail::filter_visibility_impl<T, G>(visibility, filter_width, pixel_size, const_image_view<T>{}, output, scratch, workspace,
                                         g, s, light_normal, detail::executor_ref(exec));
}

/// filter_visibility with a footprint per axis (pixel_footprint::surface_axes, surface_footprint_axes): the
/// horizontal pass uses β/`pixel_size_horizontal` pixels and the vertical pass β/`pixel_size_vertical`,
/// each pass's kernel radius and Gaussian from its own width; everything else as filter_visibility. With
/// the same view for both it computes filter_visibility's bits.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility_axes(std::type_identity_t<const_image_view<T>> visibility,
                            std::type_identity_t<const_image_view<T>> filter_width,
                            std::type_identity_t<const_image_view<T>> pixel_size_horizontal,
                            std::type_identity_t<const_image_view<T>> pixel_size_vertical, image_view<T> output,
                            std::type_identity_t<image_view<T>> scratch, filter_workspace<T>& workspace, const G& g = {},
                            const std::type_identity_t<filter_settings<T>>& s = {},
                            const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    if (pixel_size_vertical.empty())  // empty would mean "the horizontal footprint" inside
        detail::throw_invalid("filter_visibility_axes", "`pixel_size_vertical` is empty");
    detail::filter_visibility_impl<T, G>(visibility, filter_width, pixel_size_horizontal, pixel_size_vertical, output, scratch,
                                         workspace, g, s, light_normal, detail::executor_ref(exec));
}

/// The same with working memory allocated for this call and freed on return (no global or thread-local
/// state): in image space one T per pixel (and the frame's row copies, see filter_workspace), and per
/// concurrent task the lane state and row copies of a block of 64 rows. Frame loops pass a
/// filter_workspace instead.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output,
                       std::type_identity_t<image_view<T>> scratch, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    filter_workspace<T> workspace;
    filter_visibility<T>(visibility, filter_width, pixel_size, output, scratch, workspace, g, s, light_normal,
                         std::forward<Exec>(exec));
}

/// Convenience overload that allocates its own scratch image.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    image<T> scratch(visibility.width(), visibility.height());
    filter_visibility<T>(visibility, filter_width, pixel_size, output, scratch.view(), g, s, light_normal,
                         std::forward<Exec>(exec));
}

namespace detail {

/// Pixel (x, y) of a spreading pass, the scalar rule: along `Dir`, the max s1 and min s2 of the occluded
/// neighbours within `radius` (k ascending; with IDs, same object only); in the vertical pass an occluded
/// pixel of `original` keeps its own slopes.
template <pass_direction Dir, class T, class G>
[[nodiscard]] slope_pair<T> spread_pixel(const_image_view<slope_pair<T>> src, const_image_view<slope_pair<T>> original,
                                         const G& g, std::size_t radius, std::size_t x, std::size_t y) noexcept {
    if constexpr (Dir == pass_direction::vertical)
        if (original(x, y).has_occluder()) return original(x, y);  // occluded pixels keep their own slopes
    const std::size_t pos = Dir == pass_direction::horizontal ? x : y;
    const std::size_t extent = Dir == pass_direction::horizontal ? src.width() : src.height();
    const std::size_t lo = pos > radius ? pos - radius : 0;
    const std::size_t hi = std::min(pos + radius, extent - 1);
    [[maybe_unused]] std::uint32_t id = 0;
    if constexpr (G::has_ids) id = g.ids(x, y);
    slope_pair<T> acc{};
    for (std::size_t j = lo; j <= hi; ++j) {
        const std::size_t nx = Dir == pass_direction::horizontal ? j : x;
        const std::size_t ny = Dir == pass_direction::horizontal ? y : j;
        if constexpr (G::has_ids)
            if (g.ids(nx, ny) != id) continue;
        const slope_pair<T>& v = src(nx, ny);
        if (!v.has_occluder()) continue;
        acc.s1 = std::max(acc.s1, v.s1);
        acc.s2 = std::min(acc.s2, v.s2);
    }
    return acc;
}

#if AAF_SIMD_BYTES > 0
/// Vectors of consecutive slope pairs, split into their s1 and s2 lanes (the spreading's taps in vectors).
template <class T>
struct slope_lanes {
    using S = simd<T>;
    using vec = typename S::vec;
    static constexpr std::size_t N = S::lanes;
    static_assert(sizeof(slope_pair<T>) == 2 * sizeof(T), "slope_pair must hold s1, s2 without padding");

    /// s1 and s2 of the N pairs at `p` (two loads, two shuffles).
    static void load(const slope_pair<T>* p, vec& s1, vec& s2) noexcept {
        const auto* bytes = reinterpret_cast<const unsigned char*>(p);
        const vec a = S::template load<vec>(bytes), b = S::template load<vec>(bytes + sizeof(vec));
        split(a, b, s1, s2, std::make_index_sequence<N>{});
    }
    /// Writes N pairs (s1, s2) to `p`.
    static void store(slope_pair<T>* p, vec s1, vec s2) noexcept {
        vec lo, hi;
        join(s1, s2, lo, hi, std::make_index_sequence<N>{});
        auto* bytes = reinterpret_cast<unsigned char*>(p);
        std::memcpy(bytes, &lo, sizeof lo);
        std::memcpy(bytes + sizeof lo, &hi, sizeof hi);
    }
    template <std::size_t... L>
    static void split(vec a, vec b, vec& even, vec& odd, std::index_sequence<L...>) noexcept {
        even = __builtin_shufflevector(a, b, static_cast<int>(2 * L)...);
        odd = __builtin_shufflevector(a, b, static_cast<int>(2 * L + 1)...);
    }
    template <std::size_t... L>
    static void join(vec s1, vec s2, vec& lo, vec& hi, std::index_sequence<L...>) noexcept {
        lo = __builtin_shufflevector(s1, s2, static_cast<int>(L % 2 ? N + L / 2 : L / 2)...);
        hi = __builtin_shufflevector(s1, s2, static_cast<int>(L % 2 ? N + N / 2 + L / 2 : N / 2 + L / 2)...);
    }
};

/// Vectors of lanes spread together: independent max/min chains hide the latency of each tap's
/// compare-and-select (one chain per vector would wait on it every tap).
inline constexpr std::size_t spread_vector_groups = 4;

/// Spreading of `Groups` vectors of lanes (consecutive pixels from `src`'s and `ids`' first element) whose
/// taps are all inside the image: the j-th tap (j in [0, taps), ascending as spread_pixel's loop) is at
/// (first + j)·src_step pixels from the lanes' own in `src`, (first + j)·id_step elements in `ids`. Each
/// lane performs spread_pixel's comparisons in its order (max as `acc < v ? v : acc`, min as
/// `v < acc ? v : acc`, a rejected tap a select), so the results are the same bits. `Keep` (vertical):
/// where `keep` holds an occluded pixel, the lane keeps it.
template <std::size_t Groups, bool Ids, bool Keep, class T>
void spread_lane_groups(const slope_pair<T>* src, const std::uint32_t* ids, std::ptrdiff_t first, std::size_t taps,
                        std::ptrdiff_t src_step, std::ptrdiff_t id_step, const slope_pair<T>* keep,
                        slope_pair<T>* out) noexcept {
    using L = slope_lanes<T>;
    using S = typename L::S;
    using vec = typename L::vec;
    constexpr std::size_t N = L::N;
    const vec inf = S::splat(std::numeric_limits<T>::infinity());
    vec a1[Groups], a2[Groups];
    [[maybe_unused]] typename S::id cid[Groups];
    for (std::size_t g = 0; g < Groups; ++g) {
        a1[g] = S::splat(T(0)), a2[g] = inf;  // "no occluder", the identity of the max/min
        if constexpr (Ids) cid[g] = S::template load<typename S::id>(ids + g * N);
    }
    for (std::size_t j = 0; j < taps; ++j) {
        const std::ptrdiff_t t = first + static_cast<std::ptrdiff_t>(j);
        const slope_pair<T>* sj = src + t * src_step;
        [[maybe_unused]] const std::uint32_t* ij = nullptr;
        if constexpr (Ids) ij = ids + t * id_step;
        for (std::size_t g = 0; g < Groups; ++g) {
            vec s1, s2;
            L::load(sj + g * N, s1, s2);
            typename S::mask ok = s2 < inf;  // has_occluder
            if constexpr (Ids) ok = ok & S::equal(S::template load<typename S::id>(ij + g * N), cid[g]);
            a1[g] = S::select(ok & (a1[g] < s1), s1, a1[g]);
            a2[g] = S::select(ok & (s2 < a2[g]), s2, a2[g]);
        }
    }
    for (std::size_t g = 0; g < Groups; ++g) {
        if constexpr (Keep) {
            vec k1, k2;
            L::load(keep + g * N, k1, k2);
            const typename S::mask occluded = k2 < inf;
            a1[g] = S::select(occluded, k1, a1[g]), a2[g] = S::select(occluded, k2, a2[g]);
        }
        L::store(out + g * N, a1[g], a2[g]);
    }
}
#endif

/// Rows of a spreading task (the executor's unit of work). Each task is a contiguous band: its vertical
/// taps reach `radius` rows beyond it, which another band's task reads too, so a band of a few rows (or
/// rows handed out one by one, as an executor may) made every thread fetch nearly every row
/// of the image once per pass — 2 threads then moved twice the bytes of one (issue 14: 1.46x on 2 threads).
/// 64 rows: the band's halo is a third of a band at radius 10, and a 720-row frame still has 12 tasks.
/// An executor that says its concurrency (concurrency_of) gets one band per thread instead, no thinner than
/// this: the halo falls to 2·radius rows per band, and a thread's vertical pass mostly reads the rows its
/// own horizontal pass wrote (1280×720 on 2 threads, AVX-512, medians of six noisy rounds: 2.73 → 2.28 ms
/// without IDs, 3.87 → 3.50 ms with; docs/BENCHMARKS.md).
inline constexpr std::size_t spread_rows_per_task = 64;

/// One spreading pass over rows [y_begin, y_end) of `dst` (spread_pixel for every pixel): in vectors of
/// pixels where the views' rows are packed and the taps are inside the image, by the scalar rule elsewhere
/// (the borders, narrow images, strided views, builds without vectors). The vertical pass walks a column of
/// lanes down all rows of the band before the next column, so that the rows within reach of that column
/// (2·radius + 1 rows of a few hundred bytes) stay in L1 from one centre row to the next; row by row, each
/// centre row read its 2·radius + 1 tap rows of the whole width from L2 (21 × 10 KiB at 1280 px).
template <pass_direction Dir, class T, class G>
void spread_pass(const_image_view<slope_pair<T>> src, image_view<slope_pair<T>> dst, const_image_view<slope_pair<T>> original,
                 const G& g, std::size_t radius, std::size_t y_begin, std::size_t y_end) noexcept {
    [[maybe_unused]] constexpr bool horizontal = Dir == pass_direction::horizontal;
    const std::size_t w = src.width();
    [[maybe_unused]] const std::size_t h = src.height();
    // Pixels [x_from, w) of rows [y_begin, y_end) by the scalar rule.
    const auto scalar = [&](std::size_t y, std::size_t x_from, std::size_t x_to) {
        for (std::size_t x = x_from; x < x_to; ++x) dst(x, y) = spread_pixel<Dir, T>(src, original, g, radius, x, y);
    };
#if AAF_SIMD_BYTES > 0
    using L = slope_lanes<T>;
    constexpr std::size_t N = L::N, G4 = spread_vector_groups;
    // Packed rows, and (for the vertical taps' element steps) row strides in whole elements: a view may
    // pad its rows by any number of bytes, which a step counted in elements cannot express.
    const auto whole_rows = [](const auto& view) {
        using U = std::remove_cvref_t<decltype(view(0, 0))>;
        return view.packed_rows() && view.row_stride() % sizeof(U) == 0;
    };
    bool packed = whole_rows(src) && dst.packed_rows() && original.packed_rows();
    if constexpr (G::has_ids) packed = packed && whole_rows(g.ids);
    // Horizontal: lanes [x, x + N) whose taps x − r … x + N − 1 + r are all in the row. Vertical: every
    // column; the rows within reach are the same for all lanes.
    const std::size_t v_begin = horizontal ? radius : 0;
    const std::size_t v_end = horizontal ? (w >= 2 * radius + N ? w - radius : 0) : (w >= N ? w : 0);
    if (packed && v_end > v_begin) {
        // The taps' steps: 1 pixel along a row, a row stride down a column (in pixels, in IDs).
        const auto step = [&](const auto& view) {
            using U = std::remove_cvref_t<decltype(view(0, 0))>;
            return horizontal ? std::ptrdiff_t{1} : static_cast<std::ptrdiff_t>(view.row_stride() / sizeof(U));
        };
        const std::ptrdiff_t src_step = step(src);
        std::ptrdiff_t id_step = 0;
        if constexpr (G::has_ids) id_step = step(g.ids);
        // Lanes [x0, x0 + groups·N) of row y.
        const auto run = [&](auto groups, std::size_t x0, std::size_t y) {
            const std::size_t lo = horizontal ? 0 : (y > radius ? y - radius : 0);
            const std::size_t taps = horizontal ? 2 * radius + 1 : std::min(y + radius, h - 1) - lo + 1;
            const std::ptrdiff_t first = horizontal ? -static_cast<std::ptrdiff_t>(radius)
                                                    : static_cast<std::ptrdiff_t>(lo) - static_cast<std::ptrdiff_t>(y);
            const std::uint32_t* id = nullptr;
            if constexpr (G::has_ids) id = &g.ids(x0, y);
            spread_lane_groups<decltype(groups)::value, G::has_ids, !horizontal, T>(
                &src(x0, y), id, first, taps, src_step, id_step, &original(x0, y), &dst(x0, y));
        };
        const std::integral_constant<std::size_t, G4> four;
        const std::integral_constant<std::size_t, 1> one;
        if constexpr (horizontal) {
            for (std::size_t y = y_begin; y < y_end; ++y) {
                scalar(y, 0, v_begin);
                std::size_t x = v_begin;
                for (; x + G4 * N <= v_end; x += G4 * N) run(four, x, y);
                for (; x + N <= v_end; x += N) run(one, x, y);
                scalar(y, x, w);
            }
        } else {
            std::size_t x = 0;
            for (; x + G4 * N <= v_end; x += G4 * N)
                for (std::size_t y = y_begin; y < y_end; ++y) run(four, x, y);
            for (; x + N <= v_end; x += N)
                for (std::size_t y = y_begin; y < y_end; ++y) run(one, x, y);
            for (std::size_t y = y_begin; y < y_end; ++y) scalar(y, x, w);
        }
        return;
    }
#endif
    for (std::size_t y = y_begin; y < y_end; ++y) scalar(y, 0, w);
}

/// spread_slopes's work, compiled once per pixel type and IDs guide whatever the caller's executor.
template <class T, class G>
void spread_slopes_impl(image_view<slope_pair<T>> slopes, image_view<slope_pair<T>> scratch, std::uint32_t radius,
                        const G& g, executor_ref exec) {
    constexpr const char* fn = "spread_slopes";
    require_nonempty(fn, "slopes", slopes);
    const std::size_t w = slopes.width(), h = slopes.height();
    require_size(fn, "scratch", scratch, w, h);
    if constexpr (G::has_ids) require_size(fn, "guides.ids", g.ids, w, h);
    if (radius > 1024) throw_invalid(fn, "`radius` must be <= 1024 (got " + std::to_string(radius) + ")");
    if (scratch.bytes() == slopes.bytes()) throw_invalid(fn, "`scratch` must not alias `slopes`");
    if (radius == 0) return;
    // Horizontal: scratch = row-window max/min over occluded pixels. Vertical reads scratch, writes slopes,
    // skipping occluded pixels (whose values in `slopes` are still the originals it needs to keep).
    // Tasks are bands of spread_rows_per_task rows, or one per thread when the executor says how many (each
    // pixel's result does not depend on the split).
    const std::size_t threads = exec.concurrency();
    const std::size_t band = threads > 1 ? std::max(spread_rows_per_task, (h + threads - 1) / threads) : spread_rows_per_task;
    const std::size_t tasks = (h + band - 1) / band;
    const auto row = [h, band](std::size_t task) { return std::min(task * band, h); };
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        spread_pass<pass_direction::horizontal, T>(slopes, scratch, slopes, g, radius, row(b), row(e));
    });
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        spread_pass<pass_direction::vertical, T>(scratch, slopes, slopes, g, radius, row(b), row(e));
    });
}

}  // namespace detail

/// Slope spreading (FORMULAS.md §1.12, the authors' pass): every pixel with no occluder of its own takes
/// the max s1 and min s2 of the occluded pixels within `radius` pixels (a square window, computed as a
/// horizontal then a vertical pass; with an `ids` guide, same object only). Occluded pixels keep theirs.
/// Pixels that receive nothing stay "no occluder" (s2 = +∞). In place on `slopes`, with `scratch` of the
/// same size. Only `g.ids` is used.
template <class T, class G = guides<>, class Exec = sequential_executor>
void spread_slopes(image_view<slope_pair<T>> slopes, image_view<slope_pair<T>> scratch, std::uint32_t radius,
                   const G& g = {}, Exec&& exec = {}) {
    static_assert(detail::is_guides<G>::value, "aaf::spread_slopes: `g` must be an aaf::guides<...>");
    // Only the IDs matter: every guides type with (or without) them shares one compiled pass.
    using ids_only = guides<no_guide, decltype(G::ids), no_guide>;
    detail::spread_slopes_impl<T, ids_only>(slopes, scratch, radius, ids_only{{}, g.ids, {}}, detail::executor_ref(exec));
}

// The compiled mode's instantiations (config.hpp: AAF_EXTERN_TEMPLATES): every combination of the normals,
// IDs and positions guides as views (a caller's other view types are instantiated as usual), and the
// spreading with and without IDs. KEYWORD is `extern` or nothing, T float or double.
namespace detail {
template <class T>
using vector_guide = const_image_view<glm::vec<3, T>>;  // normals or positions
using id_guide = const_image_view<std::uint32_t>;
}  // namespace detail
#define AAF_DETAIL_FILTER_INSTANTIATIONS_IDS(KEYWORD, T, N, I)                                                   \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::filter_visibility_impl<T, guides<N, I, no_guide>>)                  \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::filter_visibility_impl<T, guides<N, I, detail::vector_guide<T>>>)
#define AAF_DETAIL_FILTER_INSTANTIATIONS(KEYWORD, T)                                                            \
    AAF_DETAIL_FILTER_INSTANTIATIONS_IDS(KEYWORD, T, no_guide, no_guide)                                        \
    AAF_DETAIL_FILTER_INSTANTIATIONS_IDS(KEYWORD, T, no_guide, detail::id_guide)                                \
    AAF_DETAIL_FILTER_INSTANTIATIONS_IDS(KEYWORD, T, detail::vector_guide<T>, no_guide)                         \
    AAF_DETAIL_FILTER_INSTANTIATIONS_IDS(KEYWORD, T, detail::vector_guide<T>, detail::id_guide)                 \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::spread_slopes_impl<T, guides<>>)                                    \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::spread_slopes_impl<T, guides<no_guide, detail::id_guide, no_guide>>)
#ifdef AAF_EXTERN_TEMPLATES
AAF_DETAIL_FILTER_INSTANTIATIONS(extern, float)
AAF_DETAIL_FILTER_INSTANTIATIONS(extern, double)
#endif

}  // namespace v0
}  // namespace aaf
