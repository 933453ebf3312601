// SPDX-License-Identifier: MIT
#pragma once
// Shared by the libFuzzer harnesses in fuzz/: a reader that turns the fuzzer's bytes into values, and the
// invariant check that turns a broken invariant into a crash libFuzzer reports.
//
// Values are read front to back; once the input is used up every read returns zero bytes, and zero bytes
// always decode to the *default* (a sane scene with the library's default settings). So the empty input
// is a meaningful run, and the fuzzer mutates away from it. Each scalar is a tag byte and then:
//   tag % 5 == 0  the default
//           == 1  any bit pattern of T (NaN payloads, denormals, ±Inf, anything)
//           == 2  a special value: ±0, NaN, ±Inf, ±denorm_min, ±min, ±max, ±1, epsilon, 1e±30, 0.5
//           == 3  the default times 2^k, k a signed byte (scale extremes, including overflow to ±Inf)
//           == 4  the default times (1 + j/64), j a signed byte (nearby values, sign flips)

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include <glm/vec3.hpp>

namespace aaf_fuzz {

class reader {
public:
    reader(const std::uint8_t* data, std::size_t size) noexcept : p_(data), n_(size) {}

    /// The next sizeof(U) bytes as a U (zero bytes past the end).
    template <class U>
    U raw() noexcept {
        unsigned char bytes[sizeof(U)] = {};
        const std::size_t k = std::min(n_, sizeof(U));
        if (k != 0) std::memcpy(bytes, p_, k);
        p_ += k;
        n_ -= k;
        U v;
        std::memcpy(&v, bytes, sizeof(U));
        return v;
    }
    std::uint8_t byte() noexcept { return raw<std::uint8_t>(); }
    bool flag() noexcept { return (byte() & 1u) != 0; }
    /// An integer in [0, n) (0 when n == 0).
    std::uint32_t below(std::uint32_t n) noexcept { return n == 0 ? 0 : raw<std::uint32_t>() % n; }

    /// A count: the default, any 32-bit value, or a small number (tag % 3).
    std::uint32_t count(std::uint32_t def) noexcept {
        switch (byte() % 3) {
            case 1: return raw<std::uint32_t>();
            case 2: return byte();
            default: return def;
        }
    }

    template <class T>
    T special() noexcept {
        using L = std::numeric_limits<T>;
        const T table[] = {T(0),         -T(0),         L::quiet_NaN(), L::infinity(), -L::infinity(),
                           L::denorm_min(), -L::denorm_min(), L::min(),   -L::min(),     L::max(),
                           -L::max(),    T(1),          T(-1),          L::epsilon(),  T(1e30),
                           T(1e-30),     T(-1e30),      T(0.5)};
        return table[byte() % (sizeof(table) / sizeof(table[0]))];
    }

    /// A scalar near, at or far from `def` (see the header comment).
    template <class T>
    T value(T def) noexcept {
        switch (byte() % 5) {
            case 1: return raw<T>();
            case 2: return special<T>();
            case 3: return def * std::ldexp(T(1), static_cast<int>(raw<std::int8_t>()));
            case 4: return def * (T(1) + static_cast<T>(raw<std::int8_t>()) / T(64));
            default: return def;
        }
    }

    template <class T>
    glm::vec<3, T> vec3(const glm::vec<3, T>& def) noexcept {
        return {value(def.x), value(def.y), value(def.z)};
    }

    [[nodiscard]] bool empty() const noexcept { return n_ == 0; }

private:
    const std::uint8_t* p_;
    std::size_t n_;
};

[[noreturn]] inline void fail(const char* condition, const char* file, int line) {
    std::fprintf(stderr, "aaf fuzz invariant broken: %s (%s:%d)\n", condition, file, line);
    std::abort();
}

}  // namespace aaf_fuzz

/// Aborts (a crash libFuzzer records, with its input) when an invariant does not hold.
#define AAF_FUZZ_CHECK(cond) ((cond) ? (void)0 : ::aaf_fuzz::fail(#cond, __FILE__, __LINE__))
