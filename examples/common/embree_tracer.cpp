// SPDX-License-Identifier: MIT
#include "common/embree_tracer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include <embree3/rtcore.h>

#include <glm/geometric.hpp>

namespace aaf_examples {

namespace {

const char* error_name(RTCError e) noexcept {
    switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
    }
}

/// The fraction of a segment's length at its light end where Embree's hits do not count (make_ray): 2^-20,
/// 8 to 16 float ulps, against Embree's 1-ulp error measured there.
constexpr float light_end_margin = 0x1p-20f;

/// Embree's limit on origin and direction components (FLT_LARGE in its sources); past it a ray is invalid and
/// Debian's build, which keeps Embree's assertions, aborts.
constexpr float embree_large = 1.844e18f;

bool within_embree(const glm::vec3& v) noexcept {
    return std::abs(v.x) <= embree_large && std::abs(v.y) <= embree_large && std::abs(v.z) <= embree_large;
}

/// The segment as an Embree ray over 0 < t < length·(1 − light_end_margin) (Embree accepts tnear <= t <= tfar);
/// false when invalid.
bool make_ray(const aaf::shadow_segment<float>& s, RTCRay& ray) noexcept {
    if (!within_embree(s.origin) || !within_embree(s.direction) || s.direction == glm::vec3(0.0f) || std::isnan(s.length))
        return false;
    ray.org_x = s.origin.x, ray.org_y = s.origin.y, ray.org_z = s.origin.z;
    ray.dir_x = s.direction.x, ray.dir_y = s.direction.y, ray.dir_z = s.direction.z;
    // Embree's interval is closed at tnear: with tnear = 0 a receiver lying exactly on another triangle (a corner
    // of the Cornell box, where floor and wall meet) was occluded by it at t = 0, which the contract and the BVH
    // exclude. The smallest normal float (not a denormal, which FTZ/DAZ would flush back to 0) excludes t = 0.
    ray.tnear = std::numeric_limits<float>::min();
    // The far end: Embree's distances are not exact (its AVX2 kernels put a triangle at exactly t = 1 at the
    // float below 1, measured on AMD Zen 3; the AVX-512 ones gave 1), so with tfar = the float below `length`
    // a light point lying on a triangle (the light's own geometry) was occluded by it. Hits within
    // light_end_margin of the light end are therefore the light's own position, as t = length is for the BVH.
    if (!(s.length > 0.0f)) ray.tfar = -1.0f;  // length <= 0: an empty interval
    else if (std::isinf(s.length)) ray.tfar = s.length;  // no light end
    else ray.tfar = std::nextafter(s.length - s.length * light_end_margin, 0.0f);
    ray.time = 0.0f;
    ray.mask = ~0u;
    ray.id = 0;
    ray.flags = 0;
    return true;
}

void init_hit(RTCHit& hit) noexcept {
    hit.geomID = RTC_INVALID_GEOMETRY_ID;
    hit.primID = RTC_INVALID_GEOMETRY_ID;
    hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

struct embree_tracer::impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<glm::vec3> vertices;        // a copy of the input, for nearest_hit's normals
    std::vector<glm::uvec3> triangles;      // the usable triangles, in Embree's primID order
    std::vector<std::uint32_t> ids;         // primID -> input triangle index
    std::size_t dropped = 0;
    glm::vec3 lo{0}, hi{0};                 // bounds of the usable triangles

    ~impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }

    [[noreturn]] void fail(const std::string& what) const {
        const RTCError e = device ? rtcGetDeviceError(device) : rtcGetDeviceError(nullptr);
        throw std::runtime_error("aaf_examples::embree_tracer: " + what + " failed (Embree: " + error_name(e) + ")");
    }

    /// occluder_span's second ray: the farthest hit is the nearest one seen from the light point. The back ray
    /// starts at the light point or, for a long or infinite segment, where the segment leaves the scene's bounds
    /// (no hit lies beyond; this keeps the start finite and its rounding small), and reaches a little past the
    /// nearest hit (the start carries a rounding error); `farthest` ignores what it finds before `nearest`.
    bool back_ray(const aaf::shadow_segment<float>& s, float nearest, RTCRay& back, float& end) const noexcept {
        end = s.length;
        const glm::vec3 inv = 1.0f / s.direction;
        for (int k = 0; k < 3; ++k) {
            const float t_exit = ((s.direction[k] < 0.0f ? lo[k] : hi[k]) - s.origin[k]) * inv[k];
            if (std::isfinite(t_exit) && t_exit >= nearest) end = std::min(end, t_exit * (1.0f + 1e-4f) + 1e-4f * nearest);
        }
        end = std::max(end, nearest);
        if (!make_ray({s.origin + end * s.direction, -s.direction, end}, back)) return false;
        back.tfar = (end - nearest) + 1e-5f * end;
        return true;
    }
    static float farthest(float nearest, float end, const RTCRayHit& backward) noexcept {
        return backward.hit.geomID == RTC_INVALID_GEOMETRY_ID ? nearest : std::max(nearest, end - backward.ray.tfar);
    }

    /// Nearest hit along `ray` (whose tnear/tfar are set); primID or RTC_INVALID_GEOMETRY_ID.
    RTCRayHit intersect(const RTCRay& ray) const noexcept {
        RTCRayHit rh;
        rh.ray = ray;
        init_hit(rh.hit);
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcIntersect1(scene, &context, &rh);
        return rh;
    }
};

embree_tracer::embree_tracer(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles,
                             const embree_tracer_options& options)
    : impl_(std::make_unique<impl>()) {
    const std::string where = "aaf_examples::embree_tracer: ";
    if (triangles.empty()) throw std::invalid_argument(where + "the mesh has no triangles");
    if (triangles.size() >= std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument(where + "too many triangles (" + std::to_string(triangles.size()) + ")");
    impl& m = *impl_;
    m.vertices.assign(vertices.begin(), vertices.end());
    m.triangles.reserve(triangles.size()), m.ids.reserve(triangles.size());
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        for (int k = 0; k < 3; ++k)
            if (triangles[i][k] >= vertices.size())
                throw std::invalid_argument(where + "triangle " + std::to_string(i) + " uses vertex " +
                                            std::to_string(triangles[i][k]) + " but there are only " +
                                            std::to_string(vertices.size()) + " vertices");
        // The BVH's own test, so both tracers hold the same triangles (Embree would also skip degenerate ones,
        // but a non-finite vertex is undefined behaviour there).
        if (!usable_triangle(vertices[triangles[i].x], vertices[triangles[i].y], vertices[triangles[i].z])) {
            ++m.dropped;
            continue;
        }
        m.triangles.push_back(triangles[i]);
        m.ids.push_back(static_cast<std::uint32_t>(i));
    }
    m.lo = glm::vec3(std::numeric_limits<float>::infinity()), m.hi = -m.lo;
    for (const glm::uvec3& t : m.triangles)
        for (int k = 0; k < 3; ++k) m.lo = glm::min(m.lo, vertices[t[k]]), m.hi = glm::max(m.hi, vertices[t[k]]);
    if (m.triangles.empty())
        throw std::invalid_argument(where + "none of the " + std::to_string(triangles.size()) +
                                    " triangles is usable (all have zero area or a non-finite vertex)");

    const std::string config = options.build_threads > 0 ? "threads=" + std::to_string(options.build_threads) : "";
    m.device = rtcNewDevice(config.c_str());
    if (!m.device) m.fail("rtcNewDevice");
    m.scene = rtcNewScene(m.device);
    if (!m.scene) m.fail("rtcNewScene");
    rtcSetSceneFlags(m.scene, options.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(m.scene, options.high_quality ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM);

    RTCGeometry geometry = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geometry) m.fail("rtcNewGeometry");
    // Embree's own buffers: they carry the padding Embree's SIMD loads need past the last vertex.
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), m.vertices.size()));
    auto* ib = static_cast<std::uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(std::uint32_t), m.triangles.size()));
    if (!vb || !ib) {
        rtcReleaseGeometry(geometry);
        m.fail("rtcSetNewGeometryBuffer");
    }
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
        vb[3 * i] = m.vertices[i].x, vb[3 * i + 1] = m.vertices[i].y, vb[3 * i + 2] = m.vertices[i].z;
    for (std::size_t i = 0; i < m.triangles.size(); ++i)
        ib[3 * i] = m.triangles[i].x, ib[3 * i + 1] = m.triangles[i].y, ib[3 * i + 2] = m.triangles[i].z;
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(m.scene, geometry);
    rtcReleaseGeometry(geometry);  // the scene keeps it
    rtcCommitScene(m.scene);
    if (rtcGetDeviceError(m.device) != RTC_ERROR_NONE) m.fail("building the scene");
}

embree_tracer::~embree_tracer() = default;
embree_tracer::embree_tracer(embree_tracer&&) noexcept = default;
embree_tracer& embree_tracer::operator=(embree_tracer&&) noexcept = default;

std::size_t embree_tracer::triangle_count() const noexcept { return impl_->triangles.size(); }
std::size_t embree_tracer::dropped_triangles() const noexcept { return impl_->dropped; }

ray_hit embree_tracer::nearest_hit(const glm::vec3& origin, const glm::vec3& direction, float t_max) const noexcept {
    ray_hit out;
    RTCRay ray;
    if (!make_ray({origin, direction, 1.0f}, ray) || !(t_max > 0.0f)) return out;
    ray.tfar = std::isinf(t_max) ? t_max : std::nextafter(t_max, 0.0f);  // 0 < t < t_max, as bvh
    const RTCRayHit rh = impl_->intersect(ray);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return out;
    const glm::uvec3& tri = impl_->triangles[rh.hit.primID];
    const glm::vec3 &p0 = impl_->vertices[tri.x], &p1 = impl_->vertices[tri.y], &p2 = impl_->vertices[tri.z];
    out.t = rh.ray.tfar, out.triangle = impl_->ids[rh.hit.primID], out.barycentrics = {rh.hit.u, rh.hit.v};
    out.normal = glm::vec3(glm::normalize(glm::cross(glm::dvec3(p1 - p0), glm::dvec3(p2 - p0))));
    return out;
}

float embree_tracer::nearest_occluder(const aaf::shadow_segment<float>& s) const noexcept {
    RTCRay ray;
    if (!make_ray(s, ray)) return std::numeric_limits<float>::quiet_NaN();
    const RTCRayHit rh = impl_->intersect(ray);
    return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? aaf::no_occluder<float> : rh.ray.tfar;
}

aaf::occluder_span<float> embree_tracer::occluder_span(const aaf::shadow_segment<float>& s) const noexcept {
    RTCRay ray;
    if (!make_ray(s, ray)) return {std::numeric_limits<float>::quiet_NaN(), 0.0f};
    const RTCRayHit forward = impl_->intersect(ray);
    if (forward.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
    const float nearest = forward.ray.tfar;
    RTCRay back;
    float end = 0;
    if (!impl_->back_ray(s, nearest, back, end)) return {nearest, nearest};
    const RTCRayHit backward = impl_->intersect(back);
    return {nearest, impl_->farthest(nearest, end, backward)};
}

bool embree_tracer::occluded(const aaf::shadow_segment<float>& s) const noexcept {
    RTCRay ray;
    if (!make_ray(s, ray)) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcOccluded1(impl_->scene, &context, &ray);
    return ray.tfar == -std::numeric_limits<float>::infinity();  // Embree's mark of an occluded ray
}

}  // namespace aaf_examples

// ---------------------------------------------------------------------------------------------------------
// Packets.

namespace aaf_examples {

namespace {

constexpr std::size_t lanes = embree_tracer::packet_size;
static_assert(lanes == 16, "the packet code below calls Embree's 16-wide forms");

void set_lane(RTCRay16& p, std::size_t i, const RTCRay& r) noexcept {
    p.org_x[i] = r.org_x, p.org_y[i] = r.org_y, p.org_z[i] = r.org_z, p.tnear[i] = r.tnear;
    p.dir_x[i] = r.dir_x, p.dir_y[i] = r.dir_y, p.dir_z[i] = r.dir_z, p.time[i] = r.time;
    p.tfar[i] = r.tfar, p.mask[i] = r.mask, p.id[i] = static_cast<unsigned>(i), p.flags[i] = r.flags;
}

/// A lane Embree skips (valid = 0) still gets harmless values.
void clear_lane(RTCRay16& p, std::size_t i) noexcept {
    RTCRay r;
    make_ray({glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), 0.0f}, r);
    set_lane(p, i, r);
}

template <class Out>
void require_same_size(const char* function, std::size_t segments, std::span<Out> out) {
    if (out.size() != segments)
        throw std::invalid_argument(std::string("aaf_examples::embree_tracer::") + function + ": out has " +
                                    std::to_string(out.size()) + " elements for " + std::to_string(segments) + " segments");
}

}  // namespace

void embree_tracer::occluded_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<bool> out) const {
    require_same_size("occluded_batch", segments.size(), out);
    for (std::size_t first = 0; first < segments.size(); first += lanes) {
        const std::size_t n = std::min(lanes, segments.size() - first);
        alignas(64) int valid[lanes];
        alignas(64) RTCRay16 packet;
        for (std::size_t i = 0; i < lanes; ++i) {
            RTCRay r;
            valid[i] = i < n && make_ray(segments[first + i], r) ? -1 : 0;
            if (valid[i]) set_lane(packet, i, r);
            else clear_lane(packet, i);
        }
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcOccluded16(valid, impl_->scene, &context, &packet);
        for (std::size_t i = 0; i < n; ++i)
            out[first + i] = valid[i] && packet.tfar[i] == -std::numeric_limits<float>::infinity();
    }
}

void embree_tracer::nearest_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<float> out) const {
    require_same_size("nearest_batch", segments.size(), out);
    for (std::size_t first = 0; first < segments.size(); first += lanes) {
        const std::size_t n = std::min(lanes, segments.size() - first);
        alignas(64) int valid[lanes];
        alignas(64) RTCRayHit16 packet;
        for (std::size_t i = 0; i < lanes; ++i) {
            RTCRay r;
            valid[i] = i < n && make_ray(segments[first + i], r) ? -1 : 0;
            if (valid[i]) set_lane(packet.ray, i, r);
            else clear_lane(packet.ray, i);
            packet.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
            packet.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcIntersect16(valid, impl_->scene, &context, &packet);
        for (std::size_t i = 0; i < n; ++i)
            out[first + i] = !valid[i] ? std::numeric_limits<float>::quiet_NaN()
                             : packet.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID ? aaf::no_occluder<float>
                                                                               : packet.ray.tfar[i];
    }
}

void embree_tracer::trace_batch(std::span<const aaf::shadow_segment<float>> segments,
                                std::span<aaf::occluder_span<float>> out) const {
    require_same_size("trace_batch", segments.size(), out);
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    // Chunks of up to `chunk` segments keep the scratch on the stack (no allocation per call, calls come from
    // many threads); the back rays of a chunk's occluded segments are gathered so their packets are full.
    constexpr std::size_t chunk = 16 * lanes;
    for (std::size_t first = 0; first < segments.size(); first += chunk) {
        const std::size_t n = std::min(chunk, segments.size() - first);
        const std::span<const aaf::shadow_segment<float>> in = segments.subspan(first, n);
        float nearest[chunk];
        nearest_batch(in, std::span<float>(nearest, n));
        std::uint16_t occluded[chunk];  // indices into `in` of the segments with a nearest hit
        std::size_t count = 0;
        for (std::size_t i = 0; i < n; ++i) {
            aaf::occluder_span<float>& o = out[first + i];
            if (std::isnan(nearest[i])) o = {nan, 0.0f};
            else if (nearest[i] == aaf::no_occluder<float>) o = {};
            else o = {nearest[i], nearest[i]}, occluded[count++] = static_cast<std::uint16_t>(i);
        }
        for (std::size_t k = 0; k < count; k += lanes) {
            const std::size_t m = std::min(lanes, count - k);
            alignas(64) int valid[lanes];
            alignas(64) RTCRayHit16 packet;
            float end[lanes];
            for (std::size_t l = 0; l < lanes; ++l) {
                RTCRay r;
                valid[l] = l < m && impl_->back_ray(in[occluded[k + l]], nearest[occluded[k + l]], r, end[l]) ? -1 : 0;
                if (valid[l]) set_lane(packet.ray, l, r);
                else clear_lane(packet.ray, l);
                packet.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                packet.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
            }
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            rtcIntersect16(valid, impl_->scene, &context, &packet);
            for (std::size_t l = 0; l < m; ++l) {
                if (!valid[l] || packet.hit.geomID[l] == RTC_INVALID_GEOMETRY_ID) continue;  // the span stays {nearest, nearest}
                const std::size_t i = occluded[k + l];
                out[first + i].farthest = std::max(nearest[i], end[l] - packet.ray.tfar[l]);
            }
        }
    }
}

}  // namespace aaf_examples
