// SPDX-License-Identifier: MIT
#pragma once
// Overridable configuration macros and the library's single error mechanism.

#include <stdexcept>
#include <string>

#include "version.hpp"

/// AAF_ASSERT(cond): internal invariant check. Defaults to nothing in release builds (NDEBUG) and
/// to a check that calls std::abort otherwise; define it before including any aaf header to route
/// it to your own handler. It is never used for user input: that is what aaf::invalid_argument is for.
#ifndef AAF_ASSERT
#ifdef NDEBUG
#define AAF_ASSERT(cond) ((void)0)
#else
#include <cstdio>
#include <cstdlib>
#define AAF_ASSERT(cond) \
    ((cond) ? (void)0 : (std::fprintf(stderr, "aaf: assertion failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__), std::abort()))
#endif
#endif

/// AAF_EXTERN_TEMPLATES: the compiled mode. Defined (linking the CMake target aaf::compiled defines it),
/// the headers declare the stages that do not touch the tracer (render_frame's statistics, formulas,
/// spreading, footprint and filter, the filter's and spreading's guide combinations, sample generation)
/// `extern template` for float and double, so that a translation unit compiles only the gathering over its
/// tracer and links the rest from aaf::compiled (src/compiled_float.cpp, src/compiled_double.cpp).
/// Undefined (the default), aaf is header-only. Other pixel types and guides are instantiated as usual.
///
/// AAF_DETAIL_INSTANTIATE(KEYWORD, function-template-id): an explicit instantiation of one function
/// template specialisation, declared (`extern`) or defined (no KEYWORD); each header lists its own.
#define AAF_DETAIL_INSTANTIATE(KEYWORD, ...) KEYWORD template decltype(__VA_ARGS__) __VA_ARGS__;

namespace aaf {
inline namespace v0 {

/// The one error mechanism of aaf. Every public entry point that takes user buffers or settings
/// validates them first and throws `aaf::invalid_argument` naming the offending argument
/// (e.g. "aaf::filter_visibility: `output` is 64x48 but `visibility` is 64x64"). Validation happens
/// before any output is written, so a throwing call leaves the caller's buffers untouched.
/// Compute kernels behind the entry points are `noexcept`.
class invalid_argument : public std::invalid_argument {
public:
    explicit invalid_argument(const std::string& what) : std::invalid_argument(what) {}
};

namespace detail {
[[noreturn]] inline void throw_invalid(const char* function, const std::string& message) {
    throw invalid_argument(std::string("aaf::") + function + ": " + message);
}
}  // namespace detail

}  // namespace v0
}  // namespace aaf
