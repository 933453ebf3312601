// SPDX-License-Identifier: MIT
#pragma once
// The examples' one method registry: every technique aaf-render can draw and aaf-tradeoff can measure is a
// `method` here (a name, the quantity it estimates, its cost knob and how to render one point). A technique
// family registers its methods in one function of its own file (methods_<family>.cpp or
// <family>_methods.cpp) listed in registry(); neither tool has a switch over methods.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <aaf/debug.hpp>
#include <aaf/executor.hpp>
#include <aaf/image.hpp>

#include "common/bvh.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

namespace aaf_examples {

/// What a method renders from: the scene, the examples' tracer, the camera's G-buffer and the threads.
struct render_inputs {
    const scene& s;
    const scene_tracer& tracer;  ///< the BVH or Embree (--tracer)
    const gbuffer_images& g;
    aaf::thread_pool& pool;
    std::uint32_t seed = 0;            ///< frame seed of the measured render (references use their own)
    std::filesystem::path cache = {};  ///< where references are cached between runs (empty: not cached)
    bool progress = false;             ///< long renders (references) may report progress on stderr
};

/// The quantity a method estimates; it decides which converged reference the method is judged against.
enum class quantity {
    shadow,             ///< visibility of the scene's area light, [0, 1] (sky 1, no light 0)
    ambient_occlusion,  ///< unoccluded fraction of the cosine-weighted hemisphere, [0, 1] (sky 1)
    subsurface,         ///< subsurface radiance of the scene's translucent material, displayable [0, 1]
};

/// What one render of a method at one knob value gives back.
struct method_output {
    aaf::image<float> image;                                           ///< displayable result (sky as the quantity says)
    double total_ms = 0;                                               ///< the whole render, as a user would time it
    std::uint64_t rays = 0;                                            ///< rays traced (of any kind), for rays per surface pixel
    std::size_t memory_bytes = 0;                                      ///< working memory beyond the G-buffer (maps, statistics)
    std::vector<std::pair<std::string, double>> stages_ms;             ///< named stages' times, e.g. {"rays", 12.5}
    std::vector<std::pair<std::string, aaf::image<float>>> pictures;   ///< extra pictures for aaf-render (heat maps, ...)
    std::vector<std::pair<std::string, aaf::image<aaf::rgb8>>> colour_pictures;  ///< extra RGB pictures (heat maps, bent normals)
    nlohmann::json point_settings = nlohmann::json::object();          ///< settings that vary along the knob, for the JSON
    /// Named parts of the image (1 = in the part, row-major, the image's size), e.g. the pixels one of a
    /// method's two filters gave: aaf-tradeoff splits each point's error by them ("regions" in the JSON).
    std::vector<std::pair<std::string, std::vector<unsigned char>>> regions;
};

/// One technique with its cost knob.
struct method {
    std::string name;                  ///< unique, lower_snake_case: the --method value and the JSON name
    std::string family;                ///< "mc", "aaf", "preset", "shadow_maps", "occlusion", "subsurface", "variants"
    quantity what = quantity::shadow;  ///< which reference judges it
    std::string knob;                  ///< what its sweep varies ("spp", "mu", "map_size", ...)
    std::vector<double> sweep;         ///< aaf-tradeoff's knob values, cheapest first
    std::vector<double> quick_sweep;   ///< the short sweep of --quick (tests); empty: the first two of `sweep`
    /// Monte Carlo baselines: the knob doubles from 1 until the error is below every filtered method's (or a
    /// cap), instead of following `sweep`.
    bool doubling_sweep = false;
    double default_knob = 0;           ///< aaf-render's value when --knob is not given
    std::string help;                  ///< one line for --help
    nlohmann::json settings;           ///< everything fixed besides the knob, for the JSON record
    std::function<method_output(const render_inputs&, double knob)> render;
    /// Set by a method that renders a variant of its quantity (another material or light than the quantity's
    /// reference assumes, e.g. the subsurface family's skim milk or back-lit variants): the reference image with
    /// the same material and light (samples per pixel, frame seed), which aaf-render judges it against instead
    /// of find_reference(what). aaf-tradeoff, whose curves share one reference, leaves such methods out.
    std::function<aaf::image<float>(const render_inputs&, std::uint32_t samples, std::uint32_t seed)> own_reference;
};

/// A reference image and what it cost (a lambda may return just the image).
struct reference_output {
    aaf::image<float> image;  ///< displayable, like the methods' images
    double ms = 0;            ///< rendering time (0 when read from a cache)
    bool from_cache = false;
    reference_output(aaf::image<float> i, double t = 0, bool cached = false) : image(std::move(i)), ms(t), from_cache(cached) {}
};

/// How a quantity's converged reference is made (the shadow reference is aaf_examples::reference_visibility).
struct quantity_reference {
    quantity what = quantity::shadow;
    std::string name;             ///< "shadow", "ambient_occlusion", "subsurface"
    std::string baseline_method;  ///< the Monte Carlo method equal-error ratios are taken against
    /// The reference image with `samples` samples per pixel and frame seed `seed` (two such halves with
    /// different seeds are averaged, their difference estimating the reference's own error).
    std::function<reference_output(const render_inputs&, std::uint32_t samples, std::uint32_t seed)> render;
};

/// A family's contribution: its methods and, for a new quantity, its reference.
struct method_family {
    std::vector<method> methods;
    std::vector<quantity_reference> references;
};

/// Every method of every family, in report order (the families of registry()).
[[nodiscard]] const std::vector<method>& all_methods();
/// The method called `name`; usage_error naming it and listing the known names when there is none.
[[nodiscard]] const method& find_method(const std::string& name);
/// The reference of `q`; usage_error when no family registered one.
[[nodiscard]] const quantity_reference& find_reference(quantity q);
/// Every method as `--help` lists it: name, quantity, knob (default, sweep) and its line of help.
[[nodiscard]] std::string method_list_text();
/// "shadow", "ambient_occlusion", "subsurface".
[[nodiscard]] const char* to_string(quantity q) noexcept;
/// The quantity called `name`; usage_error listing the known names otherwise.
[[nodiscard]] quantity parse_quantity(const std::string& name);

/// The families, each defined in its own file: the shadow family (Monte Carlo, aaf and its presets) here.
[[nodiscard]] method_family shadow_methods();
/// The variants family (variants_methods.cpp): image-space peers applied to Monte Carlo, progressive aaf.
[[nodiscard]] method_family variant_methods();

}  // namespace aaf_examples
