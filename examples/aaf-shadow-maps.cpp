// SPDX-License-Identifier: MIT
// aaf-shadow-maps: the figures of docs/SHADOW_MAPS.md. Renders every method of the shadow-map family
// (examples/common/shadow_maps_methods.cpp) at every knob value of its sweep on the built-in scenes, measures
// RMSE against the converged reference (the cached one aaf-render and aaf-tradeoff use), time and memory,
// prints one markdown table, and writes the visibility images of the seeds' figures as PNGs.
// (Until the registry is wired into aaf-render and aaf-tradeoff, this is where the family is run end to end.)
//
//   aaf-shadow-maps [--scenes lattice,boxes,tentacles] [--size 320x240] [--spp 1024] [--out DIR] [--cache DIR]
//                   [--threads N]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include "common/render_support.hpp"
#include "common/shadow_maps_methods.hpp"

using namespace aaf_examples;

namespace {

void write_gray(const std::filesystem::path& file, const aaf::image<float>& img) {
    std::vector<unsigned char> px(img.size());
    for (std::size_t i = 0; i < img.size(); ++i) {
        const double v = std::clamp(static_cast<double>(img.data()[i]), 0.0, 1.0);
        px[i] = static_cast<unsigned char>(std::lround(255.0 * std::pow(v, 1.0 / 2.2)));
    }
    if (!stbi_write_png(file.string().c_str(), static_cast<int>(img.width()), static_cast<int>(img.height()), 1, px.data(),
                        static_cast<int>(img.width())))
        throw std::runtime_error("cannot write " + file.string());
}

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    return report_errors("aaf-shadow-maps", [&] {
        std::vector<std::string> scenes = {"lattice", "boxes", "tentacles"};
        std::size_t width = 320, height = 240, threads = 0;
        std::uint32_t spp = 1024;
        std::filesystem::path out = "shadow-maps-out", cache = "cache";
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            const auto value = [&]() -> std::string {
                if (i + 1 >= argc) throw usage_error(a + " needs a value");
                return argv[++i];
            };
            if (a == "--scenes") scenes = split(value());
            else if (a == "--size") parse_size(value(), width, height);
            else if (a == "--spp") spp = parse_count("--spp", value(), 16, 1u << 20);
            else if (a == "--out") out = value();
            else if (a == "--cache") cache = value();
            else if (a == "--threads") threads = parse_count("--threads", value(), 1, 1024);
            else throw usage_error("unknown option " + a);
        }
        std::filesystem::create_directories(out);
        aaf::thread_pool pool(threads);
        const method_family family = shadow_map_methods();
        std::printf("| scene | method | knob | RMSE | ms | map + buffers (MiB) | tracer queries (M) |\n|---|---|---|---|---|---|---|\n");
        for (const std::string& name : scenes) {
            scene s = builtin_scene(name);
            s.width = width, s.height = height;
            const bvh tracer(s.vertices, s.triangles);
            const gbuffer_images g = render_gbuffer(s, tracer, pool);
            const reference_result ref = reference_visibility(s, g, tracer, {.spp = spp}, cache, pool, false);
            const aaf::image<float> reference = displayable(ref.visibility, g);
            const auto mask = g.surface_mask();
            write_gray(out / (name + "_reference.png"), reference);
            const render_inputs in{s, tracer, g, pool, 0};
            for (const method& m : family.methods) {
                std::vector<double> knobs = m.sweep;
                if (m.name != "sm_hard" && m.name != "sm_pcf" && m.name != "sm_accumulation") knobs = {m.default_knob};
                for (const double knob : knobs) {
                    const auto t0 = clock_type::now();
                    const method_output o = m.render(in, knob);
                    const double ms = ms_since(t0);
                    std::printf("| %s | %s | %s %g | %.4f | %.1f | %.1f | %.2f |\n", name.c_str(), m.name.c_str(), m.knob.c_str(), knob,
                                rmse(o.image, reference, mask), ms, static_cast<double>(o.memory_bytes) / (1024.0 * 1024.0),
                                static_cast<double>(o.rays) * 1e-6);
                    std::fflush(stdout);
                    write_gray(out / (name + "_" + m.name + "_" + std::to_string(static_cast<int>(knob)) + ".png"), o.image);
                }
            }
        }
        return 0;
    });
}
