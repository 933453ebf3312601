// SPDX-License-Identifier: MIT
// Non-owning strided views (strides in bytes, 0 = packed), sub-views, const conversion, bounds-checked
// access, and the small owning aaf::image.

#include <catch2/catch.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include <aaf/config.hpp>
#include <aaf/image.hpp>
#include <aaf/image_view.hpp>

namespace {
struct texel {
    float a;
    float b;
    std::int32_t c;
};

std::string what_of_at(const aaf::image_view<const float>& v, std::size_t x, std::size_t y) {
    try {
        (void)v.at(x, y);
    } catch (const aaf::invalid_argument& e) {
        return e.what();
    }
    return "<no aaf::invalid_argument thrown>";
}
}  // namespace

static_assert(std::is_trivially_copyable_v<aaf::image_view<float>>);
static_assert(std::is_convertible_v<aaf::image_view<float>, aaf::image_view<const float>>);
static_assert(!std::is_convertible_v<aaf::image_view<const float>, aaf::image_view<float>>);
static_assert(!std::is_convertible_v<aaf::image_view<int>, aaf::image_view<const float>>);
static_assert(std::is_same_v<aaf::const_image_view<float>, aaf::image_view<const float>>);
static_assert(std::is_same_v<decltype(std::declval<aaf::const_image_view<float>>()(0, 0)), const float&>);
static_assert(std::is_same_v<decltype(std::declval<aaf::image_view<float>>()(0, 0)), float&>);

TEST_CASE("image_view: packed access and default strides", "[image]") {
    std::vector<float> data(15);
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<float>(i);
    aaf::image_view v(data.data(), 5, 3);  // CTAD
    static_assert(std::is_same_v<decltype(v), aaf::image_view<float>>);
    CHECK(v.width() == 5);
    CHECK(v.height() == 3);
    CHECK(v.pixel_stride() == sizeof(float));
    CHECK(v.row_stride() == 5 * sizeof(float));
    CHECK(v.packed_rows());
    CHECK_FALSE(v.empty());
    CHECK(v.bytes() == reinterpret_cast<std::byte*>(data.data()));
    for (std::size_t y = 0; y < 3; ++y)
        for (std::size_t x = 0; x < 5; ++x) CHECK(v(x, y) == static_cast<float>(y * 5 + x));
    v(4, 2) = -1.0f;  // writes through
    CHECK(data[14] == -1.0f);

    const float* cp = data.data();
    aaf::image_view cv(cp, 5, 3);
    static_assert(std::is_same_v<decltype(cv), aaf::image_view<const float>>);
    CHECK(cv(1, 1) == 6.0f);

    aaf::image_view<float> empty;
    CHECK(empty.empty());
    CHECK(empty.width() == 0);
    CHECK(empty.height() == 0);
    CHECK(empty.bytes() == nullptr);
    CHECK(aaf::image_view<float>(data.data(), 0, 3).empty());
    CHECK(aaf::image_view<float>(data.data(), 5, 0).empty());
    CHECK(aaf::image_view<float>(nullptr, 5, 3).empty());
}

TEST_CASE("image_view: pixel and row strides in bytes", "[image]") {
    SECTION("one channel of an interleaved struct array") {
        std::vector<texel> t(4 * 3);
        for (std::size_t i = 0; i < t.size(); ++i) t[i] = texel{-1.0f, static_cast<float>(i) * 0.5f, static_cast<std::int32_t>(i)};
        aaf::image_view<float> b(&t[0].b, 4, 3, sizeof(texel));
        CHECK(b.pixel_stride() == sizeof(texel));
        CHECK(b.row_stride() == 4 * sizeof(texel));  // 0 = width · pixel_stride
        CHECK_FALSE(b.packed_rows());
        for (std::size_t y = 0; y < 3; ++y)
            for (std::size_t x = 0; x < 4; ++x) CHECK(b(x, y) == static_cast<float>(y * 4 + x) * 0.5f);
        b(2, 1) = 100.0f;
        CHECK(t[6].b == 100.0f);
        CHECK(t[6].a == -1.0f);  // neighbours in the struct untouched
        CHECK(t[6].c == 6);
    }
    SECTION("a row stride larger than the row (a 3x2 window of a 7-wide buffer)") {
        std::vector<std::uint16_t> buf(7 * 4);
        for (std::size_t i = 0; i < buf.size(); ++i) buf[i] = static_cast<std::uint16_t>(i);
        aaf::image_view<std::uint16_t> v(&buf[7 + 2], 3, 2, 0, 7 * sizeof(std::uint16_t));
        CHECK(v.pixel_stride() == sizeof(std::uint16_t));
        CHECK(v.row_stride() == 7 * sizeof(std::uint16_t));
        CHECK(v.packed_rows());
        for (std::size_t y = 0; y < 2; ++y)
            for (std::size_t x = 0; x < 3; ++x) CHECK(v(x, y) == buf[(y + 1) * 7 + x + 2]);
    }
    SECTION("both strides: every other pixel of every third row") {
        std::vector<double> buf(10 * 9);
        for (std::size_t i = 0; i < buf.size(); ++i) buf[i] = static_cast<double>(i);
        aaf::const_image_view<double> v(buf.data(), 5, 3, 2 * sizeof(double), 30 * sizeof(double));
        for (std::size_t y = 0; y < 3; ++y)
            for (std::size_t x = 0; x < 5; ++x) CHECK(v(x, y) == buf[y * 30 + 2 * x]);
    }
}

TEST_CASE("image_view: subview, clamping and out-of-range", "[image]") {
    std::vector<int> data(6 * 4);
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<int>(i);
    const aaf::image_view<int> v(data.data(), 6, 4);

    const auto s = v.subview(1, 2, 3, 2);
    CHECK(s.width() == 3);
    CHECK(s.height() == 2);
    CHECK(s.pixel_stride() == v.pixel_stride());
    CHECK(s.row_stride() == v.row_stride());
    for (std::size_t y = 0; y < 2; ++y)
        for (std::size_t x = 0; x < 3; ++x) CHECK(s(x, y) == v(x + 1, y + 2));

    const auto clamped = v.subview(4, 1, 10, 10);  // clamped at the right and bottom borders
    CHECK(clamped.width() == 2);
    CHECK(clamped.height() == 3);
    CHECK(clamped(1, 2) == v(5, 3));

    CHECK(v.subview(6, 0, 1, 1).empty());  // x out of range
    CHECK(v.subview(0, 4, 1, 1).empty());  // y out of range
    CHECK(v.subview(100, 100, 5, 5).empty());
    CHECK(v.subview(100, 100, 5, 5).width() == 0);
    CHECK(v.subview(2, 2, 0, 1).empty());  // zero width
    CHECK(v.subview(0, 0, 6, 4).bytes() == v.bytes());

    // Sub-views of sub-views, and of strided views.
    const auto ss = s.subview(1, 1, 5, 5);
    CHECK(ss.width() == 2);
    CHECK(ss.height() == 1);
    CHECK(ss(0, 0) == v(2, 3));
    const aaf::image_view<int> odd(data.data(), 3, 2, 2 * sizeof(int), 12 * sizeof(int));  // (0,0),(2,0),(4,0); rows 0, 2
    const auto os = odd.subview(1, 1, 2, 1);
    CHECK(os(0, 0) == v(2, 2));
    CHECK(os(1, 0) == v(4, 2));
    CHECK(aaf::image_view<int>{}.subview(0, 0, 1, 1).empty());
}

TEST_CASE("image_view: const conversion keeps data and strides", "[image]") {
    std::vector<texel> t(3 * 2);
    aaf::image_view<float> m(&t[0].b, 3, 2, sizeof(texel), 3 * sizeof(texel) + 0);
    const aaf::const_image_view<float> c = m;
    CHECK(c.bytes() == m.bytes());
    CHECK(c.width() == 3);
    CHECK(c.height() == 2);
    CHECK(c.pixel_stride() == sizeof(texel));
    CHECK(c.row_stride() == 3 * sizeof(texel));
    m(2, 1) = 9.5f;
    CHECK(c(2, 1) == 9.5f);
    // A function taking a const view accepts a mutable one.
    const auto sum = [](aaf::const_image_view<float> v) { return v(2, 1) + v(0, 0); };
    CHECK(sum(m) == 9.5f);
}

TEST_CASE("image_view: at() is bounds-checked and names the coordinates", "[image]") {
    std::vector<float> data(5 * 3, 2.0f);
    aaf::image_view<float> v(data.data(), 5, 3);
    CHECK(v.at(4, 2) == 2.0f);
    v.at(4, 2) = 3.0f;
    CHECK(data[14] == 3.0f);
    CHECK_THROWS_AS(v.at(5, 0), aaf::invalid_argument);
    CHECK_THROWS_AS(v.at(0, 3), aaf::invalid_argument);
    const std::string m1 = what_of_at(v, 5, 0);
    CHECK(m1.find("(5, 0)") != std::string::npos);
    CHECK(m1.find("5x3") != std::string::npos);
    CHECK(m1.find("image_view::at") != std::string::npos);
    const std::string m2 = what_of_at(v, 17, 123);
    CHECK(m2.find("(17, 123)") != std::string::npos);
    CHECK(what_of_at(aaf::const_image_view<float>{}, 0, 0).find("(0, 0)") != std::string::npos);
    // It is the library's single error type, an std::invalid_argument.
    CHECK_THROWS_AS(v.at(9, 9), std::invalid_argument);
}

TEST_CASE("image: construction, fill, reset and views", "[image]") {
    aaf::image<int> empty;
    CHECK(empty.empty());
    CHECK(empty.size() == 0);
    CHECK(empty.view().empty());

    aaf::image<int> img(4, 3, 7);
    CHECK(img.width() == 4);
    CHECK(img.height() == 3);
    CHECK(img.size() == 12);
    CHECK_FALSE(img.empty());
    for (std::size_t y = 0; y < 3; ++y)
        for (std::size_t x = 0; x < 4; ++x) CHECK(img(x, y) == 7);
    img(3, 2) = 1;
    CHECK(img.data()[11] == 1);  // row-major, packed

    aaf::image_view<int> v = img.view();
    CHECK(v.width() == 4);
    CHECK(v.height() == 3);
    CHECK(v.packed_rows());
    CHECK(v.row_stride() == 4 * sizeof(int));
    CHECK(v.bytes() == reinterpret_cast<std::byte*>(img.data()));
    v(0, 1) = 42;
    CHECK(img(0, 1) == 42);
    const aaf::image<int>& cimg = img;
    const aaf::const_image_view<int> cv = cimg.view();
    CHECK(cv(0, 1) == 42);
    CHECK(img.cview()(3, 2) == 1);
    static_assert(std::is_same_v<decltype(cimg.view()), aaf::image_view<const int>>);
    static_assert(std::is_same_v<decltype(img.cview()), aaf::image_view<const int>>);
    const auto takes_view = [](aaf::image_view<int> w) { return w.width(); };
    const auto takes_cview = [](aaf::const_image_view<int> w) { return w.height(); };
    CHECK(takes_view(img) == 4);    // implicit conversions
    CHECK(takes_cview(cimg) == 3);
    CHECK(takes_cview(img) == 3);

    img.fill(-3);
    CHECK(img.size() == 12);
    for (std::size_t y = 0; y < 3; ++y)
        for (std::size_t x = 0; x < 4; ++x) CHECK(img(x, y) == -3);

    img.reset(2, 5, 9);
    CHECK(img.width() == 2);
    CHECK(img.height() == 5);
    CHECK(img.size() == 10);
    for (std::size_t y = 0; y < 5; ++y)
        for (std::size_t x = 0; x < 2; ++x) CHECK(img(x, y) == 9);
    CHECK(img.view().row_stride() == 2 * sizeof(int));
    img.reset(3, 3);
    CHECK(img(2, 2) == 0);  // value-initialised
    img.reset(0, 0);
    CHECK(img.empty());
    CHECK(img.view().empty());
}
