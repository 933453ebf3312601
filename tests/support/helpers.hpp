// SPDX-License-Identifier: MIT
#pragma once
// Small helpers shared by the test files.

#include <functional>
#include <string>

#include <aaf/config.hpp>
#include <aaf/tracer.hpp>

namespace aaf_test {

/// The message of the aaf::invalid_argument that `f` throws, or a marker saying it threw none.
inline std::string what_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const aaf::invalid_argument& e) {
        return e.what();
    }
    return "<no aaf::invalid_argument thrown>";
}

/// An occluder_span with the given ends (hit when nearest <= farthest).
template <class T>
aaf::occluder_span<T> span(T nearest, T farthest) {
    aaf::occluder_span<T> s;
    s.nearest = nearest;
    s.farthest = farthest;
    return s;
}

}  // namespace aaf_test
