// SPDX-License-Identifier: MIT
#pragma once
// Non-owning strided 2-D views over user memory.

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>

#include "config.hpp"

namespace aaf {
inline namespace v0 {

/// A non-owning 2-D view of pixels of type `T` in memory the caller owns.
///
/// Layout follows Open Image Denoise: `pixel_stride` and `row_stride` are in *bytes*; 0 means packed
/// (`sizeof(T)` and `width * pixel_stride`). So one channel of an interleaved G-buffer can be viewed
/// in place, e.g. the normal of a `struct texel { vec3 position; vec3 normal; }` array with
/// `pixel_stride = sizeof(texel)` and `data = &texels[0].normal`.
///
/// `image_view<const T>` is the read-only flavour; `image_view<T>` converts to it implicitly.
/// An empty view (null data, 0×0) stands for "buffer not provided" where an argument is optional.
/// Pixels are accessed as `T&`, so the data pointer and both strides must be multiples of `alignof(T)`;
/// the entry points reject a misaligned view with aaf::invalid_argument.
/// Views are trivially copyable; copying a view never copies pixels.
template <class T>
class image_view {
public:
    using value_type = std::remove_cv_t<T>;
    using byte_pointer = std::conditional_t<std::is_const_v<T>, const std::byte*, std::byte*>;

    constexpr image_view() noexcept = default;

    /// Views `width`×`height` pixels starting at `data`. Strides in bytes, 0 = packed.
    constexpr image_view(T* data, std::size_t width, std::size_t height, std::size_t pixel_stride = 0,
                         std::size_t row_stride = 0) noexcept
        : data_(reinterpret_cast<byte_pointer>(data)),
          width_(width),
          height_(height),
          pixel_stride_(pixel_stride ? pixel_stride : sizeof(T)),
          row_stride_(row_stride ? row_stride : width * (pixel_stride ? pixel_stride : sizeof(T))) {}

    /// Read-only view of a mutable one.
    template <class U>
        requires(std::is_const_v<T> && std::is_same_v<std::remove_const_t<T>, U>)
    constexpr image_view(const image_view<U>& other) noexcept  // NOLINT(google-explicit-constructor)
        : data_(other.bytes()),
          width_(other.width()),
          height_(other.height()),
          pixel_stride_(other.pixel_stride()),
          row_stride_(other.row_stride()) {}

    [[nodiscard]] constexpr std::size_t width() const noexcept { return width_; }
    [[nodiscard]] constexpr std::size_t height() const noexcept { return height_; }
    [[nodiscard]] constexpr std::size_t pixel_stride() const noexcept { return pixel_stride_; }
    [[nodiscard]] constexpr std::size_t row_stride() const noexcept { return row_stride_; }
    [[nodiscard]] constexpr byte_pointer bytes() const noexcept { return data_; }
    [[nodiscard]] constexpr bool empty() const noexcept { return data_ == nullptr || width_ == 0 || height_ == 0; }

    /// Pixel (x, y); x to the right, y downwards. No bounds check (use `at` in tests).
    [[nodiscard]] T& operator()(std::size_t x, std::size_t y) const noexcept {
        return *reinterpret_cast<T*>(data_ + y * row_stride_ + x * pixel_stride_);
    }

    /// Bounds-checked access; throws aaf::invalid_argument.
    [[nodiscard]] T& at(std::size_t x, std::size_t y) const {
        if (x >= width_ || y >= height_)
            detail::throw_invalid("image_view::at", "pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                                        ") is outside the " + std::to_string(width_) + "x" +
                                                        std::to_string(height_) + " view");
        return (*this)(x, y);
    }

    /// A view of the sub-rectangle [x, x+w) × [y, y+h), clamped to this view. Cheap: tiles are views.
    [[nodiscard]] constexpr image_view subview(std::size_t x, std::size_t y, std::size_t w, std::size_t h) const noexcept {
        image_view v = *this;
        if (x >= width_ || y >= height_) {
            v.width_ = v.height_ = 0;
            return v;
        }
        v.data_ = data_ + y * row_stride_ + x * pixel_stride_;
        v.width_ = (w < width_ - x) ? w : width_ - x;
        v.height_ = (h < height_ - y) ? h : height_ - y;
        return v;
    }

    /// True when pixels are contiguous in a row (so a row can be read as a plain array).
    [[nodiscard]] constexpr bool packed_rows() const noexcept { return pixel_stride_ == sizeof(T); }

private:
    byte_pointer data_ = nullptr;
    std::size_t width_ = 0;
    std::size_t height_ = 0;
    std::size_t pixel_stride_ = sizeof(T);
    std::size_t row_stride_ = 0;
};

template <class T>
image_view(T*, std::size_t, std::size_t, std::size_t = 0, std::size_t = 0) -> image_view<T>;

/// Read-only view alias.
template <class T>
using const_image_view = image_view<const T>;

namespace detail {

/// Throws unless every pixel `view` reaches is aligned for its type: pixels are accessed as `T&`, so a
/// misaligned data pointer or stride would be undefined behaviour (UBSan: "misaligned address").
template <class T>
void require_aligned(const char* function, const char* name, const image_view<T>& view) {
    constexpr std::size_t a = alignof(typename image_view<T>::value_type);
    const bool ok = reinterpret_cast<std::uintptr_t>(view.bytes()) % a == 0 &&
                    (view.width() <= 1 || view.pixel_stride() % a == 0) && (view.height() <= 1 || view.row_stride() % a == 0);
    if (!ok)
        throw_invalid(function, std::string("`") + name + "` is not aligned for its pixel type (data, pixel stride and row "
                                                          "stride must be multiples of " + std::to_string(a) + " bytes)");
}

/// Throws unless `view` is `w`×`h` and has non-null, aligned data. `function` and `name` go into the message.
template <class T>
void require_size(const char* function, const char* name, const image_view<T>& view, std::size_t w, std::size_t h) {
    if (view.bytes() == nullptr)
        throw_invalid(function, std::string("`") + name + "` has null data");
    if (view.width() != w || view.height() != h)
        throw_invalid(function, std::string("`") + name + "` is " + std::to_string(view.width()) + "x" +
                                    std::to_string(view.height()) + " but the frame is " + std::to_string(w) + "x" +
                                    std::to_string(h));
    if (view.pixel_stride() < sizeof(typename image_view<T>::value_type) && view.width() > 1)
        throw_invalid(function, std::string("`") + name + "` has a pixel stride smaller than its pixel type");
    require_aligned(function, name, view);
}

/// Like require_size, but an empty view is accepted (the optional buffer was not provided).
template <class T>
void require_size_or_empty(const char* function, const char* name, const image_view<T>& view, std::size_t w,
                           std::size_t h) {
    if (view.bytes() == nullptr && view.width() == 0 && view.height() == 0) return;
    require_size(function, name, view, w, h);
}

/// Throws unless `view` is non-empty and aligned.
template <class T>
void require_nonempty(const char* function, const char* name, const image_view<T>& view) {
    if (view.bytes() == nullptr) throw_invalid(function, std::string("`") + name + "` has null data");
    if (view.width() == 0 || view.height() == 0)
        throw_invalid(function, std::string("`") + name + "` has zero size (" + std::to_string(view.width()) + "x" +
                                    std::to_string(view.height()) + ")");
    require_aligned(function, name, view);
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf
