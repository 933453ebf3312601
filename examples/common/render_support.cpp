// SPDX-License-Identifier: MIT
#include "common/render_support.hpp"

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <aaf/formulas.hpp>
#include <aaf/gather.hpp>

namespace aaf_examples {

namespace fs = std::filesystem;

double ms_since(clock_type::time_point t0) {
    return std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
}

std::uint32_t parse_count(const std::string& flag, const std::string& v, std::uint32_t lo, std::uint32_t hi) {
    char* end = nullptr;
    const unsigned long long n = std::strtoull(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || v[0] == '-' || n < lo || n > hi)
        throw usage_error(flag + " must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got '" + v + "')");
    return static_cast<std::uint32_t>(n);
}

void parse_size(const std::string& v, std::size_t& width, std::size_t& height) {
    const auto x = v.find('x');
    if (x == std::string::npos) throw usage_error("--size must be WxH, e.g. 640x480 (got '" + v + "')");
    width = parse_count("--size width", v.substr(0, x), 1, max_image_side);
    height = parse_count("--size height", v.substr(x + 1), 1, max_image_side);
}

bool parse_shared_option(const std::string& flag, const std::function<std::string()>& value, const shared_options& o) {
    if (flag == "--scene") o.scene = value();
    else if (flag == "--scenes-dir") o.scenes_dir = value();
    else if (flag == "--out") o.out = value();
    else if (flag == "--cache") o.cache = value();
    else if (flag == "--seed") o.seed = parse_count(flag, value(), 0, 0xffffffffu);
    else if (flag == "--tracer" && o.tracer) {
        *o.tracer = value();
        if (*o.tracer != "bvh" && *o.tracer != "embree" && *o.tracer != "embree-single")
            throw usage_error("--tracer: '" + *o.tracer + "' is not bvh, embree or embree-single");
    }
    else if (flag == "--size") {
        std::size_t width = 0, height = 0;
        parse_size(value(), width, height);
        o.width = width, o.height = height;
    } else return false;
    return true;
}

scene_tracer::scene_tracer(const scene& s, const std::string& kind) {
    if (kind == "bvh") {
        owned_bvh_ = std::make_unique<bvh>(s.vertices, s.triangles);
        bvh_ = owned_bvh_.get();
    } else if (kind == "embree" || kind == "embree-single") {
#if AAF_EXAMPLES_EMBREE
        owned_embree_ = std::make_unique<embree_tracer>(s.vertices, s.triangles);
        embree_ = owned_embree_.get();
        packets_ = kind == "embree";
#else
        throw usage_error("--tracer " + kind + ": these examples were built without Embree (install libembree-dev and "
                          "configure with -DAAF_WITH_EMBREE=ON)");
#endif
    } else {
        throw usage_error("--tracer: '" + kind + "' is not bvh, embree or embree-single");
    }
}

scene_tracer::~scene_tracer() = default;

// The batched forms: Embree's packets for "embree", else the single-ray query once per segment (the same
// answers as aaf's own loop over the single-ray form would get).
void scene_tracer::trace_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<aaf::occluder_span<float>> out) const {
#if AAF_EXAMPLES_EMBREE
    if (packets()) return embree_->trace_batch(segments, out);
#endif
    dispatch([&](const auto& t) {
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = t.occluder_span(segments[i]);
    });
}

void scene_tracer::nearest_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<float> out) const {
#if AAF_EXAMPLES_EMBREE
    if (packets()) return embree_->nearest_batch(segments, out);
#endif
    dispatch([&](const auto& t) {
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = t.nearest_occluder(segments[i]);
    });
}

void scene_tracer::occluded_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<bool> out) const {
#if AAF_EXAMPLES_EMBREE
    if (packets()) return embree_->occluded_batch(segments, out);
#endif
    dispatch([&](const auto& t) {
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = t.occluded(segments[i]);
    });
}

bool gbuffer_images::surface(std::size_t i) const noexcept { return std::isfinite(positions.data()[i].x); }

std::vector<unsigned char> gbuffer_images::surface_mask() const {
    std::vector<unsigned char> m(positions.size());
    for (std::size_t i = 0; i < m.size(); ++i) m[i] = surface(i) ? 1 : 0;
    return m;
}

gbuffer_images render_gbuffer(const scene& s, const scene_tracer& tracer, aaf::thread_pool& pool) {
    const std::size_t w = s.width, h = s.height;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    gbuffer_images g{aaf::image<glm::vec3>(w, h, glm::vec3(nan)), aaf::image<glm::vec3>(w, h, glm::vec3(nan)),
                     aaf::image<float>(w, h, 0.0f), aaf::image<float>(w, h, 0.0f),
                     aaf::image<std::uint32_t>(w, h, 0xffffffffu), 0};
    const float tan_half = std::tan(0.5f * glm::radians(s.view.fov_y_degrees));
    const glm::vec3 fwd = glm::normalize(s.view.target - s.view.position);
    const glm::vec3 right = glm::normalize(glm::cross(fwd, s.view.up)), up = glm::cross(right, fwd);
    const float aspect = static_cast<float>(w) / static_cast<float>(h);
    std::atomic<std::size_t> surfaces{0};
    pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::size_t local = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float sx = (2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(w) - 1.0f) * tan_half * aspect;
                const float sy = (1.0f - 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(h)) * tan_half;
                const glm::vec3 d = glm::normalize(fwd + sx * right + sy * up);
                const ray_hit hit = tracer.nearest_hit(s.view.position, d);
                if (!hit.hit()) continue;
                // The hit point from the triangle's vertices (barycentrics) is more accurate than o + t·d.
                const glm::uvec3 tri = s.triangles[hit.triangle];
                const glm::vec3 p = (1.0f - hit.barycentrics.x - hit.barycentrics.y) * s.vertices[tri.x] +
                                    hit.barycentrics.x * s.vertices[tri.y] + hit.barycentrics.y * s.vertices[tri.z];
                g.positions(x, y) = p;
                g.normals(x, y) = glm::dot(hit.normal, d) < 0.0f ? hit.normal : -hit.normal;  // face the camera
                const std::uint32_t object = s.triangle_object[hit.triangle];
                g.ids(x, y) = object;
                g.albedo(x, y) = s.objects[object].albedo;
                g.pixel_size(x, y) = aaf::pinhole_pixel_size(hit.t, tan_half, static_cast<std::uint32_t>(h));
                ++local;
            }
        surfaces += local;
    });
    g.surfaces = surfaces.load();
    return g;
}

aaf::image<float> displayable(const aaf::image<float>& raw, const gbuffer_images& g) {
    aaf::image<float> out(raw.width(), raw.height());
    for (std::size_t i = 0; i < raw.size(); ++i) {
        const float v = raw.data()[i];
        out.data()[i] = !g.surface(i) ? 1.0f : std::isfinite(v) ? v : 0.0f;
    }
    return out;
}

namespace {

/// 64-bit FNV-1a over bytes: the reference cache key.
struct fnv1a {
    std::uint64_t h = 1469598103934665603ull;
    void add(const void* data, std::size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    }
    template <class T>
    void add(const std::vector<T>& v) { add(v.data(), v.size() * sizeof(T)); }
    template <class T>
    void add_value(const T& v) { add(&v, sizeof(T)); }
};

}  // namespace

std::string reference_file_name(const scene& s, const reference_params& p, std::string_view engine) {
    fnv1a f;
    // Bump when the reference's meaning changes (3: the seed joined the key; 4: the tracer's engine did; 5: Embree
    // no longer counts a hit at t = 0, which darkened receivers lying on another triangle).
    const std::uint32_t format = 5;
    f.add_value(format);
    f.add_value(engine.size());
    f.add(engine.data(), engine.size());
    f.add(s.vertices);
    f.add(s.triangles);
    // Field by field: area_light ends in a bool, and hashing the struct whole read its padding bytes, whose
    // values depend on how the scene was copied (the same scene then missed its own cache).
    f.add_value(s.light.corner);
    f.add_value(s.light.edge_u);
    f.add_value(s.light.edge_v);
    f.add_value(s.light.two_sided);
    f.add_value(s.view);
    f.add_value(s.width);
    f.add_value(s.height);
    f.add_value(p.spp);
    f.add_value(p.seed);
    f.add_value(p.weighting);
    f.add_value(p.origin_offset);
    char name[64];
    std::snprintf(name, sizeof name, "reference-%016" PRIx64 ".f32", f.h);
    return name;
}

reference_result reference_visibility(const scene& s, const gbuffer_images& g, const scene_tracer& tracer,
                                      const reference_params& p, const fs::path& cache, aaf::thread_pool& pool, bool progress) {
    const auto t0 = clock_type::now();
    const std::size_t w = s.width, h = s.height;
    const fs::path file = cache / reference_file_name(s, p, tracer.engine());
    reference_result r{aaf::image<float>(w, h), false, 0};
    aaf::image<float>& ref = r.visibility;
    if (std::ifstream in{file, std::ios::binary}) {
        in.read(reinterpret_cast<char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(float)));
        if (in.gcount() == static_cast<std::streamsize>(ref.size() * sizeof(float))) {
            r.from_cache = true;
            r.ms = ms_since(t0);
            return r;
        }
    }
    // Visibility only, so the BVH's any-hit query (stops at the first hit), not aaf's occluder statistics:
    // faster, and independent of the code under test. Samples: aaf's stratified sampler, passes 1000+, so
    // they never coincide with the pipeline's passes 0 and 1; weights as the pipeline's.
    std::vector<double> visible(w * h, 0.0), total(w * h, 0.0);
    const std::uint32_t chunk = std::max<std::uint32_t>(16, std::min<std::uint32_t>(256, p.spp / 16));
    for (std::uint32_t done = 0, pass = 0; done < p.spp; done += chunk, ++pass) {
        const std::uint32_t n = std::min(chunk, p.spp - done);
        pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            std::vector<glm::vec2> uv(n);
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const glm::vec3 pos = g.positions(x, y), nrm = g.normals(x, y);
                    if (!std::isfinite(pos.x)) continue;
                    aaf::generate_samples<float>(aaf::sample_pattern::stratified,
                                                 {static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y), 1000 + pass, 0, p.seed}, uv);
                    const glm::vec3 origin = aaf::shadow_ray_origin(pos, nrm, s.light.center(), p.origin_offset);
                    double vis = 0, tot = 0;
                    for (const glm::vec2& u : uv) {
                        const glm::vec3 yl = s.light.point(u.x, u.y);
                        const float wgt = s.light.sample_weight(p.weighting, pos, nrm, yl);
                        if (!(wgt > 0.0f)) continue;
                        const glm::vec3 to = yl - origin;
                        const float len = glm::length(to);
                        tot += static_cast<double>(wgt);
                        if (!tracer.occluded({origin, to / len, len})) vis += static_cast<double>(wgt);
                    }
                    visible[y * w + x] += vis;
                    total[y * w + x] += tot;
                }
        });
        if (!progress) continue;
        const double elapsed = ms_since(t0) / 1000.0, frac = static_cast<double>(done + n) / p.spp;
        const int bar = static_cast<int>(frac * 30);
        std::fprintf(stderr, "\rreference %5u spp [%.*s%*s] %3.0f%%  ETA %6.1f s ", p.spp, bar, "##############################",
                     30 - bar, "", 100.0 * frac, elapsed / frac - elapsed);
    }
    if (progress) std::fprintf(stderr, "\n");
    for (std::size_t i = 0; i < ref.size(); ++i)
        ref.data()[i] = total[i] > 0 ? static_cast<float>(visible[i] / total[i]) : std::numeric_limits<float>::quiet_NaN();
    fs::create_directories(cache);
    const fs::path tmp = file.string() + ".tmp";
    {
        std::ofstream outf(tmp, std::ios::binary);
        outf.write(reinterpret_cast<const char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(float)));
        if (!outf) throw std::runtime_error("cannot write the reference cache " + tmp.string());
    }
    fs::rename(tmp, file);
    r.ms = ms_since(t0);
    return r;
}

mc_result render_mc(const scene& s, const gbuffer_images& g, const scene_tracer& tracer, const mc_params& p, aaf::thread_pool& pool) {
    const std::size_t w = s.width, h = s.height;
    const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{g.positions.cview(), g.normals.cview(),
                                                                       g.pixel_size.cview(), g.ids.cview()};
    aaf::sampling_settings ss;
    ss.pattern = p.pattern;
    ss.initial_samples = ss.max_samples = std::max<std::uint32_t>(p.spp, 1);
    ss.adaptive = false;
    ss.frame_seed = p.seed;
    ss.weighting = p.weighting;
    ss.origin_offset = p.origin_offset;
    mc_result r{aaf::image<float>(w, h), 0, 0, 0};
    aaf::image<aaf::occlusion_stats<float>> stats(w, h);  // allocation outside the timed part, as aaf's workspace
    const auto t0 = clock_type::now();
    stats.fill(aaf::occlusion_stats<float>{});
    // Visibility only: the BVH's any-hit query, all unfiltered Monte Carlo needs.
    r.rays = aaf::gather_visibility(gb, s.light, tracer, ss, p.pass, ss.initial_samples, stats.view(), {}, pool);
    r.rays_ms = ms_since(t0);
    pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float v = stats(x, y).visibility();
                r.visibility(x, y) = !std::isfinite(g.positions(x, y).x) ? 1.0f : std::isfinite(v) ? v : 0.0f;
            }
    });
    r.total_ms = ms_since(t0);
    return r;
}

namespace {

void require_same_size(const char* fn, const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask) {
    if (a.width() != b.width() || a.height() != b.height())
        throw std::invalid_argument(std::string(fn) + ": the images differ in size");
    if (!mask.empty() && mask.size() != a.size()) throw std::invalid_argument(std::string(fn) + ": the mask's size differs from the images'");
}

}  // namespace

double rmse(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask) {
    require_same_size("rmse", a, b, mask);
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!mask.empty() && !mask[i]) continue;
        double d = static_cast<double>(a.data()[i]) - static_cast<double>(b.data()[i]);
        if (!std::isfinite(d)) d = 1;
        sum += d * d;
        ++count;
    }
    return count ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

double max_abs_error(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask) {
    require_same_size("max_abs_error", a, b, mask);
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!mask.empty() && !mask[i]) continue;
        const double d = std::abs(static_cast<double>(a.data()[i]) - static_cast<double>(b.data()[i]));
        m = std::max(m, std::isfinite(d) ? d : 1.0);
    }
    return m;
}

double ssim(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask) {
    require_same_size("ssim", a, b, mask);
    constexpr int radius = 5;        // 11×11
    constexpr double sigma = 1.5;
    constexpr double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
    double kernel[2 * radius + 1];
    for (int i = -radius; i <= radius; ++i) kernel[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
    const auto w = static_cast<std::ptrdiff_t>(a.width()), h = static_cast<std::ptrdiff_t>(a.height());
    const auto in = [&](std::ptrdiff_t x, std::ptrdiff_t y) {
        return mask.empty() || mask[static_cast<std::size_t>(y * w + x)] != 0;
    };
    double sum = 0;
    std::size_t count = 0;
    for (std::ptrdiff_t y = 0; y < h; ++y)
        for (std::ptrdiff_t x = 0; x < w; ++x) {
            if (!in(x, y)) continue;
            double sw = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
            for (std::ptrdiff_t dy = -radius; dy <= radius; ++dy) {
                const std::ptrdiff_t yy = y + dy;
                if (yy < 0 || yy >= h) continue;
                for (std::ptrdiff_t dx = -radius; dx <= radius; ++dx) {
                    const std::ptrdiff_t xx = x + dx;
                    if (xx < 0 || xx >= w || !in(xx, yy)) continue;
                    const double k = kernel[dx + radius] * kernel[dy + radius];
                    const auto i = static_cast<std::size_t>(yy * w + xx);
                    const double va = a.data()[i], vb = b.data()[i];
                    sw += k, sa += k * va, sb += k * vb, saa += k * va * va, sbb += k * vb * vb, sab += k * va * vb;
                }
            }
            const double ma = sa / sw, mb = sb / sw;
            const double va = std::max(0.0, saa / sw - ma * ma), vb = std::max(0.0, sbb / sw - mb * mb);
            const double cov = sab / sw - ma * mb;
            const double s = ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            sum += std::isfinite(s) ? s : 0.0;
            ++count;
        }
    return count ? sum / static_cast<double>(count) : 1.0;
}

}  // namespace aaf_examples
