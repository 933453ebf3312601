// SPDX-License-Identifier: MIT
// ray_offset.hpp: Wächter & Binder's robust ray-origin offset (Ray Tracing Gems ch. 6, FORMULAS.md §6).
// The offset point is always on the normal's side, the move is a fixed number of ULPs (so it scales with
// |p|), near the origin the step is 256 ULPs of the largest coordinate, and non-finite components pass through.

#include <catch2/catch.hpp>

#include <algorithm>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <type_traits>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/ray_offset.hpp>
#include <aaf/sampler.hpp>

#include "reference/reference_ray_offset.hpp"

namespace {

template <class T>
using int_of = std::conditional_t<sizeof(T) == 4, std::int32_t, std::int64_t>;

/// Distance in representable values between two finite numbers of the same sign.
template <class T>
std::int64_t ulp_steps(T a, T b) {
    const auto ia = static_cast<std::int64_t>(std::bit_cast<int_of<T>>(a));
    const auto ib = static_cast<std::int64_t>(std::bit_cast<int_of<T>>(b));
    return ia > ib ? ia - ib : ib - ia;
}

// RTG ch. 6 constants (FORMULAS.md §6): the 1/32 threshold and the 256-ULP step, in float and double.
template <class T>
constexpr T origin_threshold = T(1.0 / 32.0);

template <class T>
std::vector<glm::vec<3, T>> test_normals() {
    std::vector<glm::vec<3, T>> ns = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    std::mt19937 rng(42u);
    std::normal_distribution<double> g(0.0, 1.0);
    for (int i = 0; i < 40; ++i) {
        const glm::dvec3 v = glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
        ns.push_back(glm::vec<3, T>(v));
    }
    ns.push_back(glm::vec<3, T>(glm::normalize(glm::dvec3(1e-3, 1, -2e-3))));  // components below 1/256: no ULP step
    return ns;
}

/// Vectors whose components mix the extremes (±0, denormals, ±1/32 and its neighbour, the largest finite
/// value, ±inf, NaN) with ordinary values at every scale: draw(false) for points, draw(true) for normals.
template <class T>
class extreme_vectors {
public:
    explicit extreme_vectors(unsigned seed) : rng_(seed) {}
    glm::vec<3, T> draw(bool normal) {
        glm::vec<3, T> v;
        for (int i = 0; i < 3; ++i) {
            const int m = mode_(rng_);
            v[i] = m == 0 ? specials_[pick_(rng_)]
                   : m == 1 ? T(u_(rng_) * (normal ? 3.0 : 0.1))
                   : m == 2 ? T(u_(rng_))
                            : T(u_(rng_) * std::pow(10.0, static_cast<int>(u_(rng_) * 30)));
        }
        return v;
    }
    double uniform() { return u_(rng_); }  ///< in [−1, 1)

private:
    static constexpr T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    static constexpr T big = std::numeric_limits<T>::max(), tiny = std::numeric_limits<T>::denorm_min();
    const T specials_[20] = {T(0), -T(0), tiny, -tiny, T(1.0 / 32.0), -T(1.0 / 32.0), std::nextafter(T(1.0 / 32.0), T(0)),
                             T(1), T(-1), T(0.5), T(-3), T(1.5), big, -big, inf, -inf, nan, T(1e-3), T(1e5), T(-2e-6)};
    std::mt19937 rng_;
    std::uniform_int_distribution<int> pick_{0, 19}, mode_{0, 3};
    std::uniform_real_distribution<double> u_{-1.0, 1.0};
};

}  // namespace

TEMPLATE_TEST_CASE("the offset point lies on the normal's side at every scale", "[offset]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const std::vector<v3> normals = test_normals<T>();
    std::mt19937 rng(7u);
    std::uniform_real_distribution<double> jitter(1.0, 2.0);
    std::size_t checked = 0;
    for (double scale : {1e-4, 1e-3, 0.01, 0.03, 1.0 / 32.0, 0.05, 0.5, 1.0, 7.5, 100.0, 1e3, 1e4, 1e5})
        for (int signs = 0; signs < 8; ++signs)
            for (const v3& n : normals) {
                const auto c = [&](int bit) { return static_cast<T>(((signs >> bit) & 1 ? -1.0 : 1.0) * scale * jitter(rng)); };
                for (const v3& p : {v3(c(0), c(1), c(2)), v3(static_cast<T>(((signs & 1) ? -1 : 1) * scale), 0, 0)}) {
                    const v3 q = aaf::offset_ray_origin(p, n);
                    const glm::dvec3 moved = glm::dvec3(q) - glm::dvec3(p);
                    INFO("p = " << p.x << ", " << p.y << ", " << p.z << "  n = " << n.x << ", " << n.y << ", " << n.z);
                    CHECK(glm::dot(moved, glm::dvec3(n)) > 0.0);
                    // Every component moves towards its normal component's sign, or not at all.
                    for (int i = 0; i < 3; ++i) CHECK(moved[i] * static_cast<double>(n[i]) >= 0.0);
                    ++checked;
                }
            }
    CHECK(checked > 8000u);
}

TEMPLATE_TEST_CASE("away from the origin the move is trunc(256 |n_i|) ULPs: tiny relative to |p|", "[offset]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const std::vector<v3> normals = test_normals<T>();
    for (double scale : {1.0 / 32.0, 0.04, 1.0, 3.0, 1e3, 1e5})
        for (double sign : {1.0, -1.0})
            for (const v3& n : normals) {
                const v3 p(static_cast<T>(sign * scale), static_cast<T>(-sign * scale * 1.5), static_cast<T>(sign * scale * 3.25));
                const v3 q = aaf::offset_ray_origin(p, n);
                for (int i = 0; i < 3; ++i) {
                    INFO("p_i = " << p[i] << " n_i = " << n[i]);
                    const auto expected = static_cast<std::int64_t>(std::trunc(256.0 * std::abs(static_cast<double>(n[i]))));
                    CHECK(ulp_steps(p[i], q[i]) == expected);
                    CHECK(expected <= 256);
                    // ≤ 256 ULPs is ≤ 256·eps relative.
                    CHECK(std::abs(static_cast<double>(q[i]) - static_cast<double>(p[i])) <=
                          256.0 * static_cast<double>(std::numeric_limits<T>::epsilon()) * std::abs(static_cast<double>(p[i])));
                }
            }
}

/// aaf's near-origin step (ray_offset.hpp): 256 ULPs of the point's largest coordinate, with a floor.
template <class T>
T fallback_step(const glm::vec<3, T>& p) {
    const T largest = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    const T floor = std::numeric_limits<T>::min() / std::numeric_limits<T>::epsilon();
    return T(256) * std::numeric_limits<T>::epsilon() * std::max(largest, floor);
}

TEMPLATE_TEST_CASE("near the origin the step is 256 ULPs of the largest coordinate", "[offset]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const std::vector<v3> normals = test_normals<T>();
    for (double scale : {0.0, 1e-30, 1e-6, 1e-4, 0.01, 0.031})
        for (double sign : {1.0, -1.0})
            for (const v3& n : normals) {
                const v3 p(static_cast<T>(sign * scale), static_cast<T>(-sign * scale * 0.5), static_cast<T>(sign * scale));
                const v3 q = aaf::offset_ray_origin(p, n);
                for (int i = 0; i < 3; ++i) {
                    REQUIRE(std::abs(p[i]) < origin_threshold<T>);
                    INFO("p_i = " << p[i] << " n_i = " << n[i]);
                    CHECK(q[i] == p[i] + fallback_step(p) * n[i]);
                }
                CHECK(glm::dot(glm::dvec3(q) - glm::dvec3(p), glm::dvec3(n)) > 0.0);
            }
    // At unit magnitude 256 ULPs of 1 (2^-15 in float, twice Wächter & Binder's fixed 2^-16); it scales with
    // the point, so a scene a few 1e-4 wide is not offset by more than its own features.
    CHECK(aaf::offset_ray_origin(v3(1, 0, 0), v3(0, 1, 0)).y == T(256) * std::numeric_limits<T>::epsilon());
    if constexpr (sizeof(T) == 4) CHECK(aaf::offset_ray_origin(v3(1, 0, 0), v3(0, 1, 0)).y == T(1.0 / 32768.0));
    const T tiny = aaf::offset_ray_origin(v3(T(1e-4), 0, 0), v3(0, 1, 0)).y;
    CHECK(tiny == T(256) * std::numeric_limits<T>::epsilon() * T(1e-4));
    CHECK(tiny < T(1e-8));
    // The threshold itself is on the ULP side; just below it, the fallback.
    const v3 n(0, 1, 0);
    const T at = origin_threshold<T>;
    const T below = std::nextafter(at, T(0));
    CHECK(ulp_steps(at, aaf::offset_ray_origin(v3(0, at, 0), n).y) == 256);
    CHECK(aaf::offset_ray_origin(v3(0, below, 0), n).y == below + fallback_step(v3(0, below, 0)));
    CHECK(aaf::offset_ray_origin(v3(0, T(0), 0), n).y == fallback_step(v3(0, 0, 0)));
    CHECK(aaf::offset_ray_origin(v3(0, T(0), 0), n).y > std::numeric_limits<T>::min());  // not denormal
    CHECK(aaf::offset_ray_origin(v3(0, T(-0.0), 0), -n).y == -fallback_step(v3(0, 0, 0)));
}

TEMPLATE_TEST_CASE("non-finite components pass through unchanged", "[offset]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const T inf = std::numeric_limits<T>::infinity();
    const T nan = std::numeric_limits<T>::quiet_NaN();
    const v3 n = glm::normalize(v3(1, 1, 1));
    const v3 q = aaf::offset_ray_origin(v3(inf, nan, -inf), n);
    CHECK(q.x == inf);
    CHECK(std::isnan(q.y));
    CHECK(q.z == -inf);
    // Finite components next to a non-finite one are still offset.
    const v3 r = aaf::offset_ray_origin(v3(T(2), nan, T(-3)), n);
    CHECK(std::isnan(r.y));
    CHECK(r.x > T(2));
    CHECK(r.z > T(-3));
    // A non-finite normal component leaves that coordinate as it is.
    const v3 s = aaf::offset_ray_origin(v3(T(2), T(5), T(-3)), v3(nan, T(1), inf));
    CHECK(s.x == T(2));
    CHECK(s.y > T(5));
    CHECK(s.z == T(-3));
}

TEST_CASE("a shadow ray from the offset point does not re-hit its own plane, at any scale", "[offset]") {
    // A plane through p with unit normal n: the offset origin must be strictly in front of it, measured in
    // double from the float values: this is what removes the need for a hand-set epsilon.
    std::mt19937 rng(99u);
    std::normal_distribution<double> g(0.0, 1.0);
    std::size_t in_front = 0, total = 0;
    for (double scale : {1e-3, 1.0, 1e3, 1e5})
        for (int i = 0; i < 500; ++i) {
            const glm::vec3 p(static_cast<float>(g(rng) * scale), static_cast<float>(g(rng) * scale), static_cast<float>(g(rng) * scale));
            const glm::vec3 n(glm::normalize(glm::dvec3(g(rng), g(rng), g(rng))));
            const glm::vec3 o = aaf::offset_ray_origin(p, n);
            const double side = glm::dot(glm::dvec3(o) - glm::dvec3(p), glm::dvec3(n));
            in_front += side > 0.0 ? 1u : 0u;
            ++total;
        }
    CHECK(in_front == total);
}

TEMPLATE_TEST_CASE("the branch-free offset gives the bits of the case-by-case definition", "[offset]", float, double) {
    // offset_ray_origin selects among its three cases without branching (gather_occlusion calls it per pixel,
    // and neighbouring pixels take different cases); the reference takes one branch per case.
    using T = TestType;
    using vec3 = glm::vec<3, T>;
    extreme_vectors<T> vectors(7u);
    for (int k = 0; k < 200000; ++k) {
        const vec3 p = vectors.draw(false), n = vectors.draw(true);
        const vec3 got = aaf::offset_ray_origin(p, n), want = aaf_ref::offset_ray_origin(p, n);
        bool same = true;
        for (int i = 0; i < 3; ++i) same = same && std::bit_cast<int_of<T>>(got[i]) == std::bit_cast<int_of<T>>(want[i]);
        INFO("p = " << p.x << ", " << p.y << ", " << p.z << "  n = " << n.x << ", " << n.y << ", " << n.z);
        REQUIRE(same);
    }
}

namespace {

/// shadow_ray_origins<T, L> against shadow_ray_origin point by point: the same bits (NaN as NaN).
template <class T, std::size_t L>
void check_origins_in_lanes(const std::vector<glm::vec<3, T>>& ps, const std::vector<glm::vec<3, T>>& ns, const glm::vec<3, T>& target,
                            double fixed_offset) {
    for (std::size_t first = 0; first + L <= ps.size(); first += L) {
        T p[3 * L], n[3 * L], out[3 * L];
        for (std::size_t k = 0; k < L; ++k)
            for (std::size_t c = 0; c < 3; ++c) p[c * L + k] = ps[first + k][c], n[c * L + k] = ns[first + k][c];
        aaf::detail::shadow_ray_origins<T, L>(p, n, target, fixed_offset, out);
        for (std::size_t k = 0; k < L; ++k) {
            const glm::vec<3, T> want = aaf::shadow_ray_origin(ps[first + k], ns[first + k], target, fixed_offset);
            bool same = true;
            for (std::size_t c = 0; c < 3; ++c) {
                const T got = out[c * L + k];
                same = same && (std::bit_cast<int_of<T>>(got) == std::bit_cast<int_of<T>>(want[c]) || (std::isnan(got) && std::isnan(want[c])));
            }
            INFO("lanes " << L << " fixed_offset " << fixed_offset << " p = " << ps[first + k].x << ", " << ps[first + k].y << ", "
                          << ps[first + k].z << "  n = " << ns[first + k].x << ", " << ns[first + k].y << ", " << ns[first + k].z);
            REQUIRE(same);
        }
    }
}

}  // namespace

TEMPLATE_TEST_CASE("shadow ray origins computed in lanes give shadow_ray_origin's bits point by point", "[offset]", float, double) {
    // gather_occlusion offsets a group of pixels at once, one per vector lane (detail::shadow_ray_origins, explicit
    // vectors when the group is one vector wide); every case of offset_ray_origin, both orientations of the
    // normal, and the fixed offsets, on points and normals that mix ordinary values with the extremes.
    using T = TestType;
    using vec3 = glm::vec<3, T>;
    extreme_vectors<T> vectors(19u);
    const auto normal = [&] {  // half of them unit normals, as a G-buffer's
        return vectors.uniform() < 0 ? vectors.draw(true)
                                     : vec3(glm::normalize(glm::dvec3(vectors.uniform(), vectors.uniform(), vectors.uniform() + 1e-3)));
    };
    std::vector<vec3> ps, ns;
    for (int k = 0; k < 48000; ++k) ps.push_back(vectors.draw(false)), ns.push_back(normal());
    const vec3 target(T(0.3), T(2), T(-0.7));
    for (const double fixed : {-1.0, 0.0, 0.01}) {
        check_origins_in_lanes<T, aaf::detail::sample_lanes<T>>(ps, ns, target, fixed);  // the explicit vectors
        check_origins_in_lanes<T, 3>(ps, ns, target, fixed);                            // the point-by-point form
    }
}
