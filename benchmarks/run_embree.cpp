// benchmarks/run_embree.cpp -- Embree 3 as the peer.
#include "run_embree.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace bench {

namespace {

/// The context handed to rtcIntersect1 for all hits: Embree passes it to the filter.
void collect(const RTCFilterFunctionNArguments* args);

struct Collector {
    RTCIntersectContext context;  ///< first member: the filter gets a pointer to it
    struct Hit {
        float t;
        std::uint32_t prim;
    };
    std::vector<Hit> hits;
    Collector() {
        rtcInitIntersectContext(&context);
        context.filter = &collect;
    }
};

/// Context filter: records every entry hit and rejects it, so traversal goes on. Embree 3.13
/// also reports the exit of each sphere (after the rejected entry); its normal points along
/// the ray and it is skipped.
void collect(const RTCFilterFunctionNArguments* args) {
    auto* c = reinterpret_cast<Collector*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        args->valid[i] = 0;
        float dn = RTCRayN_dir_x(args->ray, args->N, i) * RTCHitN_Ng_x(args->hit, args->N, i) +
                   RTCRayN_dir_y(args->ray, args->N, i) * RTCHitN_Ng_y(args->hit, args->N, i) +
                   RTCRayN_dir_z(args->ray, args->N, i) * RTCHitN_Ng_z(args->hit, args->N, i);
        if (dn > 0.0f) continue;  // the exit point
        c->hits.push_back({RTCRayN_tfar(args->ray, args->N, i), RTCHitN_primID(args->hit, args->N, i)});
    }
}

RTCRayHit make_ray(const sylva::Ray& r) {
    RTCRayHit rh{};
    rh.ray.org_x = r.origin.x;
    rh.ray.org_y = r.origin.y;
    rh.ray.org_z = r.origin.z;
    rh.ray.dir_x = r.direction.x;
    rh.ray.dir_y = r.direction.y;
    rh.ray.dir_z = r.direction.z;
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

/// All hits of one ray into c.hits, sorted by t; a sphere reported twice (a grazing entry and
/// exit) is kept once.
void trace_all(RTCScene scene, Collector& c, const sylva::Ray& ray) {
    c.hits.clear();
    RTCRayHit rh = make_ray(ray);
    rtcIntersect1(scene, &c.context, &rh);
    auto& h = c.hits;
    std::sort(h.begin(), h.end(), [](const Collector::Hit& a, const Collector::Hit& b) {
        return a.t < b.t || (a.t == b.t && a.prim < b.prim);
    });
    h.erase(std::unique(h.begin(), h.end(), [](const Collector::Hit& a, const Collector::Hit& b) {
                return a.prim == b.prim;
            }),
            h.end());
}

}  // namespace

EmbreePeer::EmbreePeer(std::size_t threads) {
    std::string config = "threads=" + std::to_string(threads);
    device_ = rtcNewDevice(config.c_str());
    if (!device_)
        throw std::runtime_error("embree: rtcNewDevice failed (error " + std::to_string(rtcGetDeviceError(nullptr)) +
                                 ")");
    rtcSetDeviceMemoryMonitorFunction(device_, &EmbreePeer::monitor, this);
}

EmbreePeer::~EmbreePeer() {
    release_scene();
    rtcReleaseDevice(device_);
}

bool EmbreePeer::monitor(void* self, ssize_t bytes, bool) {
    static_cast<EmbreePeer*>(self)->allocated_.fetch_add(bytes, std::memory_order_relaxed);
    return true;
}

void EmbreePeer::release_scene() {
    if (scene_) rtcReleaseScene(scene_);
    scene_ = nullptr;
}

void EmbreePeer::check(const char* what) const {
    RTCError e = rtcGetDeviceError(device_);
    if (e != RTC_ERROR_NONE)
        throw std::runtime_error(std::string("embree: ") + what + " failed (error " + std::to_string(e) + ")");
}

EmbreePeer::BuildTimes EmbreePeer::build(const std::vector<sylva::Sphere>& spheres) {
    release_scene();
    BuildTimes t;
    std::int64_t before = allocated_.load();
    auto t0 = Clock::now();
    scene_ = rtcNewScene(device_);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    vertices_.resize(4 * spheres.size() + 4);
    for (std::size_t i = 0; i < spheres.size(); ++i) {
        const sylva::Sphere& s = spheres[i];
        float* v = &vertices_[4 * i];
        v[0] = s.center.x, v[1] = s.center.y, v[2] = s.center.z, v[3] = s.radius;
    }
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, vertices_.data(), 0, 16,
                               spheres.size());
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
    auto t1 = Clock::now();
    rtcCommitScene(scene_);
    t.commit_ms = ms_since(t1);
    t.setup_ms = ms_since(t0);
    check("rtcCommitScene");
    scene_bytes_ = allocated_.load() - before;
    return t;
}

void EmbreePeer::first_hits(std::span<const sylva::Ray> rays, sylva::ThreadPool& pool, FirstHits& out) const {
    pool.parallel_for(0, rays.size(), 1024, [&](std::size_t lo, std::size_t hi) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (std::size_t i = lo; i < hi; ++i) {
            RTCRayHit rh = make_ray(rays[i]);
            rtcIntersect1(scene_, &ctx, &rh);
            out.id[i] = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? rh.hit.primID : kNoHit;
        }
    });
}

void EmbreePeer::all_hits(std::span<const sylva::Ray> rays, sylva::ThreadPool& pool, AllHits& out) const {
    pool.parallel_for(0, rays.size(), 1024, [&](std::size_t lo, std::size_t hi) {
        Collector c;
        for (std::size_t i = lo; i < hi; ++i) {
            trace_all(scene_, c, rays[i]);
            std::uint64_t set = 0;
            for (const auto& h : c.hits) set += mix_id(h.prim);
            out.count[i] = static_cast<std::uint32_t>(c.hits.size());
            out.set[i] = set;
        }
    });
}

}  // namespace bench

namespace bench {

HitList EmbreePeer::hit_list() const {
    return [scene = scene_](const sylva::Ray& ray) {
        Collector c;
        trace_all(scene, c, ray);
        std::vector<std::uint32_t> ids;
        for (const auto& h : c.hits) ids.push_back(h.prim);
        return ids;
    };
}

EmbreePeer::Hit EmbreePeer::first_hit(const sylva::Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh = make_ray(ray);
    rtcIntersect1(scene_, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {std::numeric_limits<float>::infinity(), kNoHit};
    return {rh.ray.tfar, rh.hit.primID};
}

void EmbreePeer::hits_along(const sylva::Ray& ray, std::vector<Hit>& out) const {
    thread_local Collector c;
    trace_all(scene_, c, ray);
    out.clear();
    for (const auto& h : c.hits) out.push_back({h.t, h.prim});
}

}  // namespace bench
