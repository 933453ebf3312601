// SPDX-License-Identifier: MIT
// The registry: the one list of technique families both example tools read.

#include "common/methods.hpp"

#include "common/occlusion_methods.hpp"
#include "common/shadow_maps_methods.hpp"
#include "common/subsurface_methods.hpp"

#include <algorithm>
#include <cstdio>

namespace aaf_examples {

namespace {

/// Every family, in report order. A new technique family adds one line here and nothing in either tool.
std::vector<method_family> registry() {
    std::vector<method_family> families;
    families.push_back(shadow_methods());
    families.push_back(variant_methods());
    families.push_back(shadow_map_methods());
    families.push_back(occlusion_methods());
    families.push_back(subsurface_methods());
    return families;
}

struct registered {
    std::vector<method> methods;
    std::vector<quantity_reference> references;
};

const registered& everything() {
    static const registered r = [] {
        registered all;
        for (method_family& f : registry()) {
            for (method& m : f.methods) all.methods.push_back(std::move(m));
            for (quantity_reference& q : f.references) all.references.push_back(std::move(q));
        }
        return all;
    }();
    return r;
}

}  // namespace

const std::vector<method>& all_methods() { return everything().methods; }

const method& find_method(const std::string& name) {
    const auto& all = all_methods();
    const auto it = std::find_if(all.begin(), all.end(), [&](const method& m) { return m.name == name; });
    if (it != all.end()) return *it;
    std::string list;
    for (const method& m : all) list += (list.empty() ? "" : ", ") + m.name;
    throw usage_error("unknown method '" + name + "' (known: " + list + ")");
}

const quantity_reference& find_reference(quantity q) {
    for (const quantity_reference& r : everything().references)
        if (r.what == q) return r;
    throw usage_error(std::string("no reference is registered for the quantity '") + to_string(q) + "'");
}

std::string method_list_text() {
    const auto num = [](double v) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", v);
        return std::string(buf);
    };
    std::string t = "\nmethods (--method NAME [--knob X] in aaf-render, --quantity Q --methods A,B in aaf-tradeoff):\n";
    for (const method& m : all_methods()) {
        std::string sweep;
        if (m.doubling_sweep) sweep = "1, 2, 4, ... doubling";
        else
            for (double v : m.sweep) sweep += (sweep.empty() ? "" : ", ") + num(v);
        t += "  " + m.name + " [" + to_string(m.what) + "; " + m.knob + " = " + num(m.default_knob) + "; sweep " + sweep + "]\n      " +
             m.help + "\n";
    }
    return t;
}

const char* to_string(quantity q) noexcept {
    switch (q) {
        case quantity::shadow: return "shadow";
        case quantity::ambient_occlusion: return "ambient_occlusion";
        case quantity::subsurface: return "subsurface";
    }
    return "?";
}

quantity parse_quantity(const std::string& name) {
    for (quantity q : {quantity::shadow, quantity::ambient_occlusion, quantity::subsurface})
        if (name == to_string(q)) return q;
    throw usage_error("unknown quantity '" + name + "' (known: shadow, ambient_occlusion, subsurface)");
}

}  // namespace aaf_examples
