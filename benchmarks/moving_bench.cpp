// sylva-moving-bench: moving spheres (issue 14, item 5). The same spheres move for F frames
// (each along its own direction, by 2 % of the unit cube's side times sin(2 pi f / 16 + i));
// per frame every index follows the motion by refit and, separately, by rebuild:
//   bih     bih::refit / bih::rebuild of a bih::Config::for_queries() tree (plus the RangePayload encode)
//   kd      kdtree::refit_elements / rebuild_elements (plus kdtree::encode_elements)
//   octree  octree::update_elements (refit, or a rebuild where a sphere left the lattice) /
//           rebuild_elements (plus octree::encode_elements)
//   embree  Embree 3 over RTC_GEOMETRY_TYPE_SPHERE_POINT: refit = scene RTC_BUILD_QUALITY_LOW
//           with the geometry at RTC_BUILD_QUALITY_REFIT (Embree refits the geometry's BVH when
//           only the vertex buffer changed); rebuild = the default scene (MEDIUM) committed anew
// Reported per index and mode: cold (frame 1, the first update after the initial build) and
// steady (median of frames 2..F) update times, the initial build, and after the last frame the
// first-hit rate over R rays (the refitted tree's quality against the rebuilt one's). A check
// compares every index's first hits on the moved spheres against brute force over a sample of
// rays (the run fails on a mismatch). All structures run in one process on the same spheres.
//
//   sylva-moving-bench [--count N] [--frames F] [--rays R] [--threads T] [--json FILE] [--quick]
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/refit.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/elements_refit.hpp>
#if SYLVA_BENCH_EMBREE
#include <embree3/rtcore.h>
#endif

#include "bench.hpp"

using namespace sylva;
using bench::median;
using bench::time_ms;

namespace {

struct Args {
    std::size_t count = 1000000, frames = 8, rays = 200000, threads = 0;
    std::string json;
};

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        std::string s = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(s + " needs a value");
            return argv[++i];
        };
        auto number = [&](double lo, double hi) {
            std::string v = value();
            char* end = nullptr;
            double x = std::strtod(v.c_str(), &end);
            if (v.empty() || *end || !(x >= lo && x <= hi)) throw std::invalid_argument(s + ": '" + v + "' is out of range");
            return static_cast<std::size_t>(x);
        };
        if (s == "--count") a.count = number(1, 1e8);
        else if (s == "--frames") a.frames = number(2, 1000);
        else if (s == "--rays") a.rays = number(1, 1e8);
        else if (s == "--threads") a.threads = number(0, 1024);
        else if (s == "--json") a.json = value();
        else if (s == "--quick") a.count = 10000, a.frames = 3, a.rays = 10000;
        else throw std::invalid_argument("unknown option '" + s + "'");
    }
    return a;
}

/// Frame f of the motion of `base` into `out`.
void move(const std::vector<Sphere>& base, std::size_t f, std::vector<Sphere>& out, ThreadPool& pool) {
    out.resize(base.size());
    pool.parallel_for(0, base.size(), 16384, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            float a = float(i) * 2.39996323f, z = 1.0f - 2.0f * float(i % 1024) / 1023.0f, r = std::sqrt(1.0f - z * z);
            out[i] = base[i];
            out[i].center += 0.02f * std::sin(6.2831853f * float(f) / 16.0f + float(i)) * vec3(r * std::cos(a), r * std::sin(a), z);
        }
    });
}

/// One index under test: its first build, its per-frame update and its first-hit query.
struct Entrant {
    std::string name, mode;
    std::function<void(std::span<const Sphere>)> build, update;
    std::function<std::optional<std::uint32_t>(const Ray&)> first;  ///< after update
    std::vector<double> ms;
    double build_ms = 0.0;
};

#if SYLVA_BENCH_EMBREE
/// Embree over sphere points; refit mode: two-level scene, geometry at REFIT quality.
class Embree {
public:
    Embree(std::size_t threads, bool refit) : refit_(refit) {
        std::string cfg = "threads=" + std::to_string(threads);
        device_ = rtcNewDevice(cfg.c_str());
        if (!device_) throw std::runtime_error("rtcNewDevice failed");
    }
    ~Embree() {
        if (scene_) rtcReleaseScene(scene_);
        rtcReleaseDevice(device_);
    }
    Embree(const Embree&) = delete;
    Embree& operator=(const Embree&) = delete;
    void build(std::span<const Sphere> s) {
        if (scene_) rtcReleaseScene(scene_);
        scene_ = rtcNewScene(device_);
        if (refit_) rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_LOW);
        geom_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        if (refit_) rtcSetGeometryBuildQuality(geom_, RTC_BUILD_QUALITY_REFIT);
        vertices_ = static_cast<float*>(rtcSetNewGeometryBuffer(geom_, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                                4 * sizeof(float), s.size()));
        fill(s);
        rtcCommitGeometry(geom_);
        rtcAttachGeometry(scene_, geom_);
        rtcReleaseGeometry(geom_);
        rtcCommitScene(scene_);
        check("build");
    }
    void update(std::span<const Sphere> s) {
        if (!refit_) {
            build(s);  // the rebuild: a new scene over the moved spheres
            return;
        }
        fill(s);
        rtcUpdateGeometryBuffer(geom_, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(geom_);
        rtcCommitScene(scene_);
        check("refit");
    }
    std::optional<std::uint32_t> first(const Ray& r) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh{};
        rh.ray.org_x = r.origin.x, rh.ray.org_y = r.origin.y, rh.ray.org_z = r.origin.z;
        rh.ray.dir_x = r.direction.x, rh.ray.dir_y = r.direction.y, rh.ray.dir_z = r.direction.z;
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = INFINITY;
        rh.ray.mask = 0xFFFFFFFFu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_, &ctx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
        return rh.hit.primID;
    }

private:
    void fill(std::span<const Sphere> s) {
        for (std::size_t i = 0; i < s.size(); ++i) {
            vertices_[4 * i] = s[i].center.x;
            vertices_[4 * i + 1] = s[i].center.y;
            vertices_[4 * i + 2] = s[i].center.z;
            vertices_[4 * i + 3] = s[i].radius;
        }
    }
    void check(const char* what) const {
        if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw std::runtime_error(std::string("embree ") + what + " failed");
    }
    bool refit_;
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    RTCGeometry geom_ = nullptr;
    float* vertices_ = nullptr;
};
#endif

}  // namespace

int main(int argc, char** argv) try {
    Args a = parse(argc, argv);
    ThreadPool pool(a.threads);
    std::vector<Sphere> base = bench::make_spheres(a.count, bench::Distribution::Uniform, 0x30F1u);
    std::vector<Ray> rays = bench::make_rays(a.rays, 0x30F2u);
    std::vector<Sphere> now = base;
    std::span<const Sphere> cur(now);
    bench::Report report;
    const std::string label = bench::size_label(a.count) + "/uniform";

    bih::Tree bt[2];
    std::vector<std::uint32_t> bw[2];
    kdtree::ElementTree kt[2];
    std::vector<std::uint32_t> kw[2];
    octree::ElementTree ot[2];
    std::vector<std::uint32_t> ow[2];
    std::size_t octree_fallbacks = 0;
    const bih::Config bcfg = bih::Config::for_queries();
    std::vector<Entrant> es;
    for (int m = 0; m < 2; ++m) {
        const bool refit = m == 0;
        const std::string mode = refit ? "refit" : "rebuild";
        es.push_back({"bih", mode, [&, m](auto s) { bt[m] = bih::build(s, bcfg, pool); bw[m] = bih::encode(bt[m], s, bih::RangePayload{}); },
                      [&, m, refit](auto s) {
                          if (refit) bih::refit(bt[m], s, pool);
                          else bih::rebuild(bt[m], s, bcfg, pool);
                          bw[m] = bih::encode(bt[m], s, bih::RangePayload{});
                      },
                      [&, m](const Ray& r) -> std::optional<std::uint32_t> {
                          auto h = bih::first_hit(std::span<const std::uint32_t>(bw[m]), bt[m], cur, r);
                          return h ? std::optional<std::uint32_t>(h->element) : std::nullopt;
                      },
                      {},
                      0.0});
        es.push_back({"kd", mode, [&, m](auto s) { kt[m] = kdtree::build_elements(s, {}, pool); kw[m] = kdtree::encode_elements(kt[m]); },
                      [&, m, refit](auto s) {
                          if (refit) kdtree::refit_elements(kt[m], s, {}, pool);
                          else kdtree::rebuild_elements(kt[m], s, {}, pool);
                          kw[m] = kdtree::encode_elements(kt[m]);
                      },
                      [&, m](const Ray& r) -> std::optional<std::uint32_t> {
                          auto h = kdtree::first_hit(std::span<const std::uint32_t>(kw[m]), cur, r);
                          return h ? std::optional<std::uint32_t>(h->element) : std::nullopt;
                      },
                      {},
                      0.0});
        es.push_back({"octree", mode, [&, m](auto s) { ot[m] = octree::build_elements(s, {}, pool); ow[m] = octree::encode_elements(ot[m]); },
                      [&, m, refit](auto s) {
                          if (refit) octree_fallbacks += octree::update_elements(ot[m], s, {}, pool) ? 0u : 1u;
                          else octree::rebuild_elements(ot[m], s, {}, pool);
                          ow[m] = octree::encode_elements(ot[m]);
                      },
                      [&, m](const Ray& r) -> std::optional<std::uint32_t> {
                          auto h = octree::first_hit(std::span<const std::uint32_t>(ow[m]), cur, r);
                          return h ? std::optional<std::uint32_t>(h->element) : std::nullopt;
                      },
                      {},
                      0.0});
    }
#if SYLVA_BENCH_EMBREE
    Embree em_refit(pool.concurrency(), true), em_rebuild(pool.concurrency(), false);
    for (Embree* e : {&em_refit, &em_rebuild})
        es.push_back({"embree", e == &em_refit ? "refit" : "rebuild", [e](auto s) { e->build(s); },
                      [e](auto s) { e->update(s); }, [e](const Ray& r) { return e->first(r); }, {}, 0.0});
#endif
    for (Entrant& e : es) e.build_ms = time_ms([&] { e.build(cur); });
    for (std::size_t f = 1; f <= a.frames; ++f) {
        move(base, f, now, pool);
        cur = std::span<const Sphere>(now);
        for (std::size_t k = 0; k < es.size(); ++k) {  // alternate the order between frames
            Entrant& e = es[f % 2 ? k : es.size() - 1 - k];
            e.ms.push_back(time_ms([&] { e.update(cur); }));
        }
        std::cerr << "sylva-moving-bench: frame " << f << " of " << a.frames << std::endl;
    }
    // Correctness on the last frame: every index's first hit against brute force on a sample.
    std::size_t failures = 0, sample = std::min<std::size_t>(rays.size(), a.count > 100000 ? 200 : 1000);
    for (std::size_t i = 0; i < sample; ++i) {
        std::optional<std::uint32_t> want;
        float best = INFINITY;
        for (std::uint32_t k = 0; k < now.size(); ++k)
            if (auto t = now[k].intersect(rays[i], {}); t && t->t0 < best) best = t->t0, want = k;
        for (const Entrant& e : es) {
            auto got = e.first(rays[i]);
            bool ok = got == want;
            if (!ok && got && want && e.name == "embree") {  // Embree's own sphere test: a tie or a graze
                auto tg = now[*got].intersect(rays[i], {});
                ok = tg && std::abs(tg->t0 - best) <= 1e-4f * std::max(1.0f, best);
            }
            if (!ok) ++failures, std::cerr << e.name << " " << e.mode << ": ray " << i << " disagrees with brute force\n";
        }
    }
    for (Entrant& e : es) {
        std::vector<std::uint32_t> hit(rays.size());
        double q = time_ms([&] {
            pool.parallel_for(0, rays.size(), 512, [&](std::size_t i0, std::size_t i1) {
                for (std::size_t i = i0; i < i1; ++i) hit[i] = e.first(rays[i]).value_or(~0u);
            });
        });
        std::string name = "moving/" + label + "/" + e.name + "/" + e.mode;
        std::vector<double> steady(e.ms.begin() + 1, e.ms.end());
        report.add(name, e.name == "embree" ? "embree" : "sylva", "build_ms", e.build_ms, "ms");
        report.add(name, e.name == "embree" ? "embree" : "sylva", "cold_update_ms", e.ms.front(), "ms");
        report.add(name, e.name == "embree" ? "embree" : "sylva", "steady_update_ms", median(steady), "ms");
        report.add(name, e.name == "embree" ? "embree" : "sylva", "first_hit_rays_per_s",
                   double(rays.size()) / (std::max(q, 1e-6) / 1000.0), "rays/s");
        std::cout << name << ": build " << e.build_ms << " ms, update cold " << e.ms.front() << " ms, steady (median of "
                  << steady.size() << ") " << median(steady) << " ms, first hit after frame " << a.frames << ": "
                  << double(rays.size()) / (std::max(q, 1e-6) / 1000.0) / 1e6 << " Mrays/s\n";
    }
    std::cout << "threads " << pool.concurrency() << ", " << a.count << " spheres, " << a.frames << " frames, " << rays.size()
              << " rays; octree refits that fell back to a rebuild: " << octree_fallbacks << "; brute-force check over "
              << sample << " rays: " << failures << " mismatches\n";
    if (!a.json.empty()) report.write_json(a.json);
    return failures ? 1 : 0;
} catch (const std::exception& e) {
    std::cerr << "sylva-moving-bench: " << e.what() << "\n";
    return 2;
}
