// SPDX-License-Identifier: MIT
#pragma once
// A small owning image for scratch buffers, tests and examples.

#include <cstddef>
#include <vector>

#include "image_view.hpp"

namespace aaf {
inline namespace v0 {

/// An owning, packed, row-major image. Meant for scratch, tests and examples; the library's
/// entry points take `image_view`s so callers keep their own memory layout.
template <class T>
class image {
public:
    image() = default;
    image(std::size_t width, std::size_t height, const T& fill = T{})
        : width_(width), height_(height), pixels_(width * height, fill) {}

    [[nodiscard]] std::size_t width() const noexcept { return width_; }
    [[nodiscard]] std::size_t height() const noexcept { return height_; }
    [[nodiscard]] std::size_t size() const noexcept { return pixels_.size(); }
    [[nodiscard]] bool empty() const noexcept { return pixels_.empty(); }

    [[nodiscard]] T& operator()(std::size_t x, std::size_t y) noexcept { return pixels_[y * width_ + x]; }
    [[nodiscard]] const T& operator()(std::size_t x, std::size_t y) const noexcept { return pixels_[y * width_ + x]; }

    [[nodiscard]] T* data() noexcept { return pixels_.data(); }
    [[nodiscard]] const T* data() const noexcept { return pixels_.data(); }

    [[nodiscard]] image_view<T> view() noexcept { return {pixels_.data(), width_, height_}; }
    [[nodiscard]] image_view<const T> view() const noexcept { return {pixels_.data(), width_, height_}; }
    [[nodiscard]] image_view<const T> cview() const noexcept { return view(); }
    operator image_view<T>() noexcept { return view(); }              // NOLINT(google-explicit-constructor)
    operator image_view<const T>() const noexcept { return view(); }  // NOLINT(google-explicit-constructor)

    /// Resizes, keeping no pixel values (every pixel becomes `fill`). Reuses capacity when it can.
    void reset(std::size_t width, std::size_t height, const T& fill = T{}) {
        width_ = width;
        height_ = height;
        pixels_.assign(width * height, fill);
    }

    void fill(const T& value) { pixels_.assign(pixels_.size(), value); }

private:
    std::size_t width_ = 0;
    std::size_t height_ = 0;
    std::vector<T> pixels_;
};

}  // namespace v0
}  // namespace aaf
