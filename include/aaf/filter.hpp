// SPDX-License-Identifier: MIT
#pragma once
// The separable, spatially varying, guided Gaussian filter of visibility (FORMULAS.md §1.8, §1.11–§1.14)
// and the slope-spreading pass that gives unoccluded pixels their occluded neighbours' slopes (§1.12).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "executor.hpp"
#include "guides.hpp"
#include "image.hpp"
#include "image_view.hpp"
#include "occlusion_stats.hpp"
#include "settings.hpp"

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

/// Squared distance between the centre `p` and a neighbour at `q`, projected on the light plane (§1.11).
template <class T>
[[nodiscard]] T light_plane_distance2(const glm::vec<3, T>& q, const glm::vec<3, T>& p,
                                      const glm::vec<3, T>& light_normal) noexcept {
    const glm::vec<3, T> dp = q - p;
    const T along = glm::dot(dp, light_normal);
    return std::max(glm::dot(dp, dp) - along * along, T(0));  // NaN stays NaN (std::max keeps its first argument)
}

/// The same for neighbour (nx, ny) of the guides' positions.
template <class T, class G>
[[nodiscard]] T light_plane_distance2(const G& g, std::size_t nx, std::size_t ny, const glm::vec<3, T>& p,
                                      const glm::vec<3, T>& light_normal) noexcept {
    return light_plane_distance2<T>(g.positions(nx, ny), p, light_normal);
}

/// The result of a pass for a non-finite centre: the Gaussian average of its accepted finite neighbours.
/// Such a centre has no weight of its own, so the result is a ratio of neighbour weights only, and for a
/// narrow kernel every exp(−e) can underflow to 0 in T (e.g. β/d < 0.07 px in float: exp(−1/(2·0.07²)) = 0)
/// although valid neighbours exist. The weights are normalised, so evaluate them relative to the largest,
/// exp(−(e − e_min)); `centre` is returned only when no neighbour is accepted.
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
        for (std::size_t x = 0; x < w; ++x) ox[x] = in[x].x, oy[x] = in[x].y, oz[x] = in[x].z;
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

/// Structure-of-arrays copies of rows of the pass's input and of the guides it uses, `stride` elements per
/// row, so that the lanes read contiguous, aligned-type arrays whatever the caller's pixel strides.
/// Elements that stand for pixels outside the image hold a NaN value (and NaN normals), which every tap
/// rejects; with normals, a non-finite value also gets a NaN normal, so the normal test rejects it alone.
template <class T, class G, offset_space Space>
struct tap_rows {
    static constexpr bool normals = G::has_normals;
    static constexpr bool ids = G::has_ids;
    static constexpr bool positions = Space != offset_space::image;
    std::size_t stride = 0;
    // Not value-initialised: every element is written by `load` or `fill` before the lanes read it.
    std::unique_ptr<T[]> v, nx, ny, nz, px, py, pz;
    std::unique_ptr<std::uint32_t[]> id;

    std::size_t capacity = 0;

    /// Makes room for `rows` rows of `row_stride` elements; reallocates only to grow.
    void resize(std::size_t rows, std::size_t row_stride) {
        stride = row_stride;
        const std::size_t n = rows * row_stride;
        if (n <= capacity) return;
        capacity = n;
        v.reset(new T[n]);
        if constexpr (normals) nx.reset(new T[n]), ny.reset(new T[n]), nz.reset(new T[n]);
        if constexpr (ids) id.reset(new std::uint32_t[n]);
        if constexpr (positions) px.reset(new T[n]), py.reset(new T[n]), pz.reset(new T[n]);
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
            for (std::size_t x = 0; x < w; ++x) n[x] = std::abs(value[x]) <= max_finite ? n[x] : nan;
        }
        if constexpr (ids) copy_row(g.ids, y, &id[o]);
        if constexpr (positions) copy_row(g.positions, y, &px[o], &py[o], &pz[o]);
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

/// What a pass works in, kept from task to task and from the horizontal to the vertical pass of one
/// filter_visibility call: allocated (and its pages first touched) once per call and thread, not per task.
template <class T, class G, offset_space Space>
struct pass_workspace {
    lane_state<T> st;
    tap_rows<T, G, Space> rows;
    std::vector<unsigned char> lok, rok;  // light plane: the lanes' accepted taps

    explicit pass_workspace(std::size_t w) : st(w), lok(filter_lane_block), rok(filter_lane_block) {}
};

/// The workspaces of one call, each lent to one task at a time (as many exist as tasks ever ran at once).
template <class W>
class workspace_pool {
public:
    explicit workspace_pool(std::size_t width) : width_(width) {}

    /// Calls f(workspace) with a free workspace (a new one if none is free).
    template <class F>
    void lend(F&& f) {
        std::unique_ptr<W> ws;
        {
            const std::lock_guard lock(mutex_);
            if (!free_.empty()) ws = std::move(free_.back()), free_.pop_back();
        }
        if (!ws) ws = std::make_unique<W>(width_);
        f(*ws);
        const std::lock_guard lock(mutex_);
        free_.push_back(std::move(ws));
    }

private:
    std::size_t width_;
    std::mutex mutex_;
    std::vector<std::unique_ptr<W>> free_;
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

/// Light-plane taps at distance k: the guide masks vectorise; the distances, std::exp and the sums run
/// per lane in the scalar order (−k side, then +k side). `Tangent`: distances are projected on each
/// centre's own normal (offset_space::tangent_plane) instead of `ln`.
template <class T, bool Normals, bool Ids, bool Tangent = false>
void light_plane_taps(std::size_t n, T k, T cos_threshold, const glm::vec<3, T>& ln, const T* AAF_DETAIL_RESTRICT radius,
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
    // The distance through the same glm expression as the per-pixel definition, so that a compiler that
    // contracts a·b + c into fma contracts both alike (bitwise equal results).
    const auto add = [&](std::size_t i, const auto& c) {
        const glm::vec<3, T> p{cpx[i], cpy[i], cpz[i]}, q{c.px[i], c.py[i], c.pz[i]};
        glm::vec<3, T> axis = ln;
        if constexpr (Tangent) axis = {cnx[i], cny[i], cnz[i]};
        const T weight = std::exp(-light_plane_distance2<T>(q, p, axis) * inv_two_beta2[i]);
        if (!std::isfinite(weight)) return;  // NaN position
        sum[i] += weight * c.v[i];
        wsum[i] += weight;
    };
    for (std::size_t i = 0; i < n; ++i) {
        if (lok[i]) add(i, L);
        if (rok[i]) add(i, R);
    }
}

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
    for (std::size_t x = 0; x < w; ++x) {
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

/// Whether a centre of the row with a kernel is non-finite (those take the scalar rule; rare).
template <class T>
[[nodiscard]] bool any_non_finite_centre(std::size_t w, const T* AAF_DETAIL_RESTRICT cv,
                                         const T* AAF_DETAIL_RESTRICT full_radius) noexcept {
    constexpr T max_finite = std::numeric_limits<T>::max();
    bool any = false;
    for (std::size_t x = 0; x < w; ++x) any = any | ((full_radius[x] > T(0)) & !(std::abs(cv[x]) <= max_finite));
    return any;
}

/// Σw·v / Σw for lanes with taps (or the centre when the weights sum to 0), the centre for the others.
template <class T>
void normalise_lanes(std::size_t w, const T* AAF_DETAIL_RESTRICT cv, const T* AAF_DETAIL_RESTRICT radius,
                     const T* AAF_DETAIL_RESTRICT sum, const T* AAF_DETAIL_RESTRICT wsum, T* AAF_DETAIL_RESTRICT out) noexcept {
    for (std::size_t x = 0; x < w; ++x) out[x] = ((radius[x] > T(0)) & (wsum[x] > T(0))) ? sum[x] / wsum[x] : cv[x];
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
template <pass_direction Dir, offset_space Space, class T, class G>
void filter_pass(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta, const_image_view<T> pixel_size,
                 const G& g, const glm::vec<3, T>& light_normal, const filter_settings<T>& s, std::size_t y_begin,
                 std::size_t y_end, std::size_t* row_reach, T* decay, pass_workspace<T, G, Space>& ws) {
    constexpr bool horizontal = Dir == pass_direction::horizontal;
    constexpr bool light_plane = Space != offset_space::image;  // world offsets: light or tangent plane
    const std::size_t w = src.width(), h = src.height();
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));

    lane_state<T>& st = ws.st;
    tap_rows<T, G, Space>& rows = ws.rows;
    std::vector<unsigned char>&lok = ws.lok, &rok = ws.rok;  // light plane: the lanes' accepted taps
    const std::size_t margin =
        s.max_radius + filter_distances_per_sweep;  // horizontal: NaN elements left and right of the row
    std::size_t first_row = 0;                      // vertical: image row held in buffer row 0
    std::size_t nan_row = 0;  // vertical: the buffer row of NaN values standing for rows outside the image
    if constexpr (horizontal) {
        rows.resize(1, w + 2 * margin);
        rows.fill(0, 0, margin);  // `load` writes only [margin, margin + w)
        rows.fill(0, margin + w, w + 2 * margin);
    }

    // Blocks of filter_rows_per_task rows, whatever the executor hands out, so that the vertical pass's
    // copy of the rows within reach stays cache-sized (and its buffer is reused).
    for (std::size_t block = y_begin; block < y_end; block += filter_rows_per_task) {
        const std::size_t block_end = std::min(block + filter_rows_per_task, y_end);
        if constexpr (!horizontal) {
            std::size_t reach = 0;  // the largest radius among the block's centres (from the horizontal pass)
            for (std::size_t y = block; y < block_end; ++y) reach = std::max(reach, row_reach[y]);
            const std::size_t r = reach + filter_distances_per_sweep;  // margin for the last group
            first_row = block > r ? block - r : 0;
            const std::size_t last_row = std::min(h, block_end + r);
            nan_row = last_row - first_row;
            rows.resize(nan_row + 1, w);
            rows.fill(nan_row, 0, w);
            for (std::size_t y = first_row; y < last_row; ++y) rows.load(y - first_row, 0, src, g, y);
        }
        for (std::size_t y = block; y < block_end; ++y) {
            if constexpr (horizontal) rows.load(0, margin, src, g, y);  // the margins keep their NaN values
            const std::size_t centre_at = horizontal ? margin : (y - first_row) * w;  // the centres in `rows`
            const auto C = rows.at(centre_at);
            // Set up the lanes. A lane with taps has a finite centre (and position); the others get radius 0.
            const auto [bw, dw] = row_radii(st, beta, pixel_size, s, y);
            if constexpr (horizontal) row_reach[y] = largest_radius(st.full_radius.data(), w);
            setup_lanes<light_plane>(w, C.v, C.px, C.py, C.pz, st.full_radius.data(), bw, dw, st.radius.data(), st.a.data(), st.wk.data(), st.sum.data(),
                                     st.wsum.data(), st.inv_two_beta2.data());
            if constexpr (!light_plane) {
                // w_k = exp(-k² a) by the recurrence w_k = w_{k-1}·m_k, m_k = exp(-(2k-1)a), q = exp(-2a).
                T* AAF_DETAIL_RESTRICT m1 = decay + y * w;
                if constexpr (horizontal)  // every pixel with a kernel (the vertical pass's centres may be finite)
                    for (std::size_t x = 0; x < w; ++x) m1[x] = st.full_radius[x] > T(0) ? std::exp(-st.a[x]) : T(0);
                T* AAF_DETAIL_RESTRICT mk = st.mk.data();
                T* AAF_DETAIL_RESTRICT q = st.q.data();
                for (std::size_t x = 0; x < w; ++x) mk[x] = m1[x], q[x] = m1[x] * m1[x];
            }
            for (std::size_t x0 = 0; x0 < w; x0 += filter_lane_block) {
                const std::size_t n = std::min(filter_lane_block, w - x0);
                const std::size_t steps = largest_radius(&st.radius[x0], n);
                const auto Cb = rows.at(centre_at + x0);
                using cursor = typename tap_rows<T, G, Space>::cursor;
                const auto side = [&](std::size_t k, bool plus) -> cursor {
                    if constexpr (horizontal) return rows.at(plus ? centre_at + x0 + k : centre_at + x0 - k);
                    if (plus) return rows.at((y + k < h ? y + k - first_row : nan_row) * w + x0);
                    return rows.at((k <= y ? y - k - first_row : nan_row) * w + x0);
                };
                if constexpr (light_plane) {
                    for (std::size_t k = 1; k <= steps; ++k) {
                        light_plane_taps<T, G::has_normals, G::has_ids, Space == offset_space::tangent_plane>(
                            n, static_cast<T>(k), cos_threshold, light_normal, &st.radius[x0], &st.inv_two_beta2[x0],
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
            normalise_lanes(w, C.v, st.radius.data(), st.sum.data(), st.wsum.data(), st.out.data());
            store_row(st.out.data(), dst, y);
            if (!any_non_finite_centre(w, C.v, st.full_radius.data())) continue;
            for (std::size_t x = 0; x < w; ++x) {
                const T centre = C.v[x];
                if (!(st.full_radius[x] > T(0)) || std::isfinite(centre)) continue;
                // A non-finite centre with a kernel (rare): the scalar rule.
                glm::vec<3, T> p{0};
                T inv_two_beta2 = T(0);
                if constexpr (light_plane) {
                    p = g.positions(x, y);
                    if (!std::isfinite(p.x + p.y + p.z)) continue;  // no position: copied
                    inv_two_beta2 = st.inv_two_beta2[x];
                }
                const std::size_t pos = horizontal ? x : y, extent = horizontal ? w : h;
                const T beta_px = beta(x, y) / pixel_size(x, y);
                dst(x, y) = non_finite_centre_average<Dir, Space>(
                    src, g, guide_center<T, G>(g, x, y), p, light_normal, x, y, pos, extent,
                    static_cast<std::size_t>(st.full_radius[x]), T(1) / (T(2) * beta_px * beta_px), inv_two_beta2,
                    cos_threshold, centre);
            }
        }
    }
}

#undef AAF_DETAIL_RESTRICT

}  // namespace detail

/// Filters `visibility` into `output` with the separable guided Gaussian: a horizontal pass into
/// `scratch`, then a vertical pass into `output`, each with the centre pixel's width (as the authors).
///
/// * `filter_width` β is per pixel in world units (formulas.hpp); β ≤ 0 or NaN = leave that pixel as is.
/// * `pixel_size` d is each pixel's projected footprint (world units); image-space offsets use β/d pixels.
/// * Offsets in `offset_space::light_plane` need `guides.positions` and use distances projected on the
///   plane of `light_normal`; the window is still sized by β/d. `offset_space::tangent_plane` needs
///   `guides.positions` and `guides.normals` (unit) and projects on each centre's own tangent plane.
/// * Non-finite visibility never spreads: such neighbours are skipped; a non-finite centre takes its
///   valid neighbours' average (or stays as it was if it has none).
/// * `output` may alias neither `visibility` nor `scratch`. All views must have the same size.
/// * Working memory is allocated per call and freed on return (no global or thread-local state): in image
///   space one T per pixel (each pixel's Gaussian decay, shared by both passes), and per concurrent task
///   the lane state and row copies of a block of 64 rows.
/// Throws aaf::invalid_argument (before touching `output`) on mismatched sizes or invalid settings.
/// T is deduced from `output` only, so mutable views and `image<T>`s convert to the read-only inputs.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output,
                       std::type_identity_t<image_view<T>> scratch, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    constexpr const char* fn = "filter_visibility";
    detail::require_nonempty(fn, "visibility", visibility);
    const std::size_t w = visibility.width(), h = visibility.height();
    detail::require_size(fn, "filter_width", filter_width, w, h);
    detail::require_size(fn, "pixel_size", pixel_size, w, h);
    detail::require_size(fn, "output", output, w, h);
    detail::require_size(fn, "scratch", scratch, w, h);
    detail::require_guides(fn, g, w, h);
    validate(s, fn);
    if (output.bytes() == visibility.bytes() || output.bytes() == scratch.bytes() ||
        scratch.bytes() == visibility.bytes())
        detail::throw_invalid(fn, "`output`, `scratch` and `visibility` must be distinct buffers");
    // Tasks are blocks of rows; every pixel's result is independent of how they are split.
    const std::size_t tasks = (h + detail::filter_rows_per_task - 1) / detail::filter_rows_per_task;
    const auto row = [h](std::size_t task) { return std::min(task * detail::filter_rows_per_task, h); };
    std::vector<std::size_t> row_reach(h);  // each row's largest kernel radius, from the horizontal pass
    if (s.space == offset_space::tangent_plane) {
        if constexpr (!G::has_positions || !G::has_normals) {
            detail::throw_invalid(fn, "`settings.space` is tangent_plane but `guides.positions` or `guides.normals` is absent");
        } else {
            constexpr auto space = offset_space::tangent_plane;
            detail::workspace_pool<detail::pass_workspace<T, G, space>> pool(w);
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::horizontal, space, T>(visibility, scratch, filter_width, pixel_size, g, light_normal, s, row(b), row(e), row_reach.data(), static_cast<T*>(nullptr), ws); });
            });
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::vertical, space, T>(scratch, output, filter_width, pixel_size, g, light_normal, s, row(b), row(e), row_reach.data(), static_cast<T*>(nullptr), ws); });
            });
            return;
        }
    }
    if (s.space == offset_space::light_plane) {
        if constexpr (!G::has_positions) {
            detail::throw_invalid(fn, "`settings.space` is light_plane but `guides.positions` is absent");
        } else {
            const T len = glm::length(light_normal);
            if (!(len > T(0)) || !std::isfinite(len)) detail::throw_invalid(fn, "`light_normal` must be a finite non-zero vector");
            const glm::vec<3, T> n = light_normal / len;
            detail::workspace_pool<detail::pass_workspace<T, G, offset_space::light_plane>> pool(w);
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::horizontal, offset_space::light_plane, T>(visibility, scratch, filter_width, pixel_size, g, n, s, row(b), row(e), row_reach.data(), static_cast<T*>(nullptr), ws); });
            });
            exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
                pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::vertical, offset_space::light_plane, T>(scratch, output, filter_width, pixel_size, g, n, s, row(b), row(e), row_reach.data(), static_cast<T*>(nullptr), ws); });
            });
            return;
        }
    }
    // Not value-initialised: the horizontal pass writes every element before the vertical pass reads it.
    const std::unique_ptr<T[]> decay(new T[w * h]);
    detail::workspace_pool<detail::pass_workspace<T, G, offset_space::image>> pool(w);
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::horizontal, offset_space::image, T>(visibility, scratch, filter_width, pixel_size, g, light_normal, s, row(b), row(e), row_reach.data(), decay.get(), ws); });
    });
    exec.parallel_for(tasks, [&](std::size_t b, std::size_t e) {
        pool.lend([&](auto& ws) { detail::filter_pass<detail::pass_direction::vertical, offset_space::image, T>(scratch, output, filter_width, pixel_size, g, light_normal, s, row(b), row(e), row_reach.data(), decay.get(), ws); });
    });
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

template <pass_direction Dir, class T, class G>
void spread_pass(const_image_view<slope_pair<T>> src, image_view<slope_pair<T>> dst, const_image_view<slope_pair<T>> original,
                 const G& g, std::size_t radius, std::size_t y_begin, std::size_t y_end) noexcept {
    const std::size_t w = src.width(), h = src.height();
    for (std::size_t y = y_begin; y < y_end; ++y) {
        for (std::size_t x = 0; x < w; ++x) {
            if constexpr (Dir == pass_direction::vertical) {
                if (original(x, y).has_occluder()) {  // occluded pixels keep their own slopes
                    dst(x, y) = original(x, y);
                    continue;
                }
            }
            const std::size_t pos = Dir == pass_direction::horizontal ? x : y;
            const std::size_t extent = Dir == pass_direction::horizontal ? w : h;
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
            dst(x, y) = acc;
        }
    }
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
    constexpr const char* fn = "spread_slopes";
    detail::require_nonempty(fn, "slopes", slopes);
    const std::size_t w = slopes.width(), h = slopes.height();
    detail::require_size(fn, "scratch", scratch, w, h);
    if constexpr (G::has_ids) detail::require_size(fn, "guides.ids", g.ids, w, h);
    if (radius > 1024) detail::throw_invalid(fn, "`radius` must be <= 1024 (got " + std::to_string(radius) + ")");
    if (scratch.bytes() == slopes.bytes()) detail::throw_invalid(fn, "`scratch` must not alias `slopes`");
    if (radius == 0) return;
    // Horizontal: scratch = row-window max/min over occluded pixels. Vertical reads scratch, writes slopes,
    // skipping occluded pixels (whose values in `slopes` are still the originals it needs to keep).
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::spread_pass<detail::pass_direction::horizontal, T>(slopes, scratch, slopes, g, radius, b, e);
    });
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::spread_pass<detail::pass_direction::vertical, T>(scratch, slopes, slopes, g, radius, b, e);
    });
}

}  // namespace v0
}  // namespace aaf
