// benchmarks/moving.cpp -- moving spheres (moving.hpp): the motion, the eight entrants, the
// brute-force check, the table and the records.
#include "moving.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
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

using namespace sylva;

namespace bench {
namespace {

/// octree::ElementConfig::refit_margin of both octree entrants.
constexpr float kOctreeRefitMargin = 0.05f;

using Spheres = std::span<const Sphere>;
using Hit = std::optional<std::uint32_t>;

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

/// One index under test: its first build, its per-frame update and its first-hit query over
/// the spheres it was last built or updated over.
struct Entrant {
    std::string name, mode;
    std::function<void(Spheres)> build, update;
    std::function<Hit(const Ray&)> first;
    std::vector<double> ms;  ///< update time per frame
    double build_ms = 0.0;
    double rays_per_s = 0.0;  ///< first hits after the last frame
    std::size_t mismatches = 0;
};

/// An entrant named `name` in refit or rebuild mode, its functions yet to be set.
Entrant named(const char* name, bool refit) {
    Entrant e;
    e.name = name;
    e.mode = refit ? "refit" : "rebuild";
    return e;
}

Entrant bih_entrant(bool refit, ThreadPool& pool) {
    struct State {
        bih::Tree tree;
        std::vector<std::uint32_t> words;
        Spheres s;
    };
    auto st = std::make_shared<State>();
    const bih::Config cfg = bih::Config::for_queries();
    auto encode = [st](Spheres s) { st->s = s, st->words = bih::encode(st->tree, s, bih::RangePayload{}); };
    Entrant e = named("bih", refit);
    e.build = [st, cfg, encode, &pool](Spheres s) { st->tree = bih::build(s, cfg, pool), encode(s); };
    e.update = [st, cfg, encode, refit, &pool](Spheres s) {
        if (refit) bih::refit(st->tree, s, pool);
        else bih::rebuild(st->tree, s, cfg, pool);
        encode(s);
    };
    e.first = [st](const Ray& r) -> Hit {
        auto h = bih::first_hit(std::span<const std::uint32_t>(st->words), st->tree, st->s, r);
        return h ? Hit(h->element) : std::nullopt;
    };
    return e;
}

Entrant kd_entrant(bool refit, ThreadPool& pool) {
    struct State {
        kdtree::ElementTree tree;
        std::vector<std::uint32_t> words;
        Spheres s;
    };
    auto st = std::make_shared<State>();
    auto encode = [st](Spheres s) { st->s = s, st->words = kdtree::encode_elements(st->tree); };
    Entrant e = named("kd", refit);
    e.build = [st, encode, &pool](Spheres s) { st->tree = kdtree::build_elements(s, {}, pool), encode(s); };
    e.update = [st, encode, refit, &pool](Spheres s) {
        if (refit) kdtree::refit_elements(st->tree, s, {}, pool);
        else kdtree::rebuild_elements(st->tree, s, {}, pool);
        encode(s);
    };
    e.first = [st](const Ray& r) -> Hit {
        auto h = kdtree::first_hit(std::span<const std::uint32_t>(st->words), st->s, r);
        return h ? Hit(h->element) : std::nullopt;
    };
    return e;
}

/// Both octree entrants' configuration: a lattice with room for the motion (amplitude 0.02 of
/// the unit cube), so that refits stay refits instead of falling back to a rebuild.
octree::ElementConfig octree_config() {
    octree::ElementConfig c;
    c.refit_margin = kOctreeRefitMargin;
    return c;
}

/// The octree's refit counts in `fallbacks` the frames where it fell back to a rebuild.
Entrant octree_entrant(bool refit, ThreadPool& pool, std::size_t& fallbacks) {
    struct State {
        octree::ElementTree tree;
        std::vector<std::uint32_t> words;
        Spheres s;
    };
    auto st = std::make_shared<State>();
    const octree::ElementConfig cfg = octree_config();
    auto encode = [st](Spheres s) { st->s = s, st->words = octree::encode_elements(st->tree); };
    Entrant e = named("octree", refit);
    e.build = [st, cfg, encode, &pool](Spheres s) { st->tree = octree::build_elements(s, cfg, pool), encode(s); };
    e.update = [st, cfg, encode, refit, &pool, &fallbacks](Spheres s) {
        if (refit) fallbacks += octree::update_elements(st->tree, s, cfg, pool) ? 0u : 1u;
        else octree::rebuild_elements(st->tree, s, cfg, pool);
        encode(s);
    };
    e.first = [st](const Ray& r) -> Hit {
        auto h = octree::first_hit(std::span<const std::uint32_t>(st->words), st->s, r);
        return h ? Hit(h->element) : std::nullopt;
    };
    return e;
}

#if SYLVA_BENCH_EMBREE
/// Embree over sphere points; refit mode: scene at LOW quality, geometry at REFIT quality.
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
    void build(Spheres s) {
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
    void update(Spheres s) {
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
    Hit first(const Ray& r) const {
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
    void fill(Spheres s) {
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

Entrant embree_entrant(bool refit, std::size_t threads) {
    auto em = std::make_shared<Embree>(threads, refit);
    Entrant e = named("embree", refit);
    e.build = [em](Spheres s) { em->build(s); };
    e.update = [em](Spheres s) { em->update(s); };
    e.first = [em](const Ray& r) { return em->first(r); };
    return e;
}
#endif

/// The eight entrants (six without Embree): the refits first, then the rebuilds.
std::vector<Entrant> make_entrants(ThreadPool& pool, std::size_t& octree_fallbacks) {
    std::vector<Entrant> es;
    for (bool refit : {true, false}) {
        es.push_back(bih_entrant(refit, pool));
        es.push_back(kd_entrant(refit, pool));
        es.push_back(octree_entrant(refit, pool, octree_fallbacks));
    }
#if SYLVA_BENCH_EMBREE
    for (bool refit : {true, false}) es.push_back(embree_entrant(refit, pool.concurrency()));
#endif
    return es;
}

/// Builds every entrant over `base`, then moves the spheres (into `now`) for the frames.
void run_frames(std::vector<Entrant>& es, const std::vector<Sphere>& base, std::vector<Sphere>& now,
                const MovingArgs& a, ThreadPool& pool, const std::string& who) {
    now = base;
    for (Entrant& e : es) e.build_ms = time_ms([&] { e.build(Spheres(now)); });
    for (std::size_t f = 1; f <= a.frames; ++f) {
        move(base, f, now, pool);
        for (std::size_t k = 0; k < es.size(); ++k) {  // alternate the order between frames
            Entrant& e = es[f % 2 ? k : es.size() - 1 - k];
            settle();
            e.ms.push_back(time_ms([&] { e.update(Spheres(now)); }));
        }
        std::cerr << who << ": moving " << size_label(a.count) << ": frame " << f << " of " << a.frames << std::endl;
    }
}

/// Every entrant's first hits on the moved spheres against brute force over the first `sample`
/// rays; counts each entrant's mismatches and returns their sum.
std::size_t check_brute_force(std::vector<Entrant>& es, const std::vector<Sphere>& now, std::span<const Ray> rays,
                              std::size_t sample) {
    std::size_t failures = 0;
    for (std::size_t i = 0; i < sample; ++i) {
        Hit want;
        float best = INFINITY;
        for (std::uint32_t k = 0; k < now.size(); ++k)
            if (auto t = now[k].intersect(rays[i], {}); t && t->t0 < best) best = t->t0, want = k;
        for (Entrant& e : es) {
            Hit got = e.first(rays[i]);
            bool ok = got == want;
            if (!ok && got && want && e.name == "embree") {  // Embree's own sphere test: a tie or a graze
                auto tg = now[*got].intersect(rays[i], {});
                ok = tg && std::abs(tg->t0 - best) <= 1e-4f * std::max(1.0f, best);
            }
            if (!ok) {
                ++failures, ++e.mismatches;
                std::cerr << e.name << " " << e.mode << ": ray " << i << " disagrees with brute force\n";
            }
        }
    }
    return failures;
}

/// Each entrant's first-hit rate over all rays after the last frame.
void measure_queries(std::vector<Entrant>& es, std::span<const Ray> rays, ThreadPool& pool) {
    std::vector<std::uint32_t> hit(rays.size());
    for (Entrant& e : es) {
        settle();
        double q = time_ms([&] {
            pool.parallel_for(0, rays.size(), 512, [&](std::size_t i0, std::size_t i1) {
                for (std::size_t i = i0; i < i1; ++i) hit[i] = e.first(rays[i]).value_or(~0u);
            });
        });
        e.rays_per_s = per_s(double(rays.size()), q);
    }
}

std::string case_name(const std::string& label, const Entrant& e) { return "moving/" + label + "/" + e.name + "/" + e.mode; }

void add_records(Report& report, const std::vector<Entrant>& es, const std::string& label, const MovingArgs& a,
                 const MovingResult& r) {
    const std::string work = "moving/" + label;
    report.add(work, "workload", "spheres", double(a.count), "spheres");
    report.add(work, "workload", "frames", double(a.frames), "frames");
    report.add(work, "workload", "rays", double(a.rays), "rays");
    report.add(work, "workload", "brute_force_rays", double(r.sample), "rays");
    for (const Entrant& e : es) {
        const bool peer = e.name == "embree";
        const std::string name = case_name(label, e), impl = peer ? "embree" : "sylva";
        std::string to;
#if SYLVA_BENCH_EMBREE
        if (!peer) to = "moving/" + label + "/embree/" + e.mode;
#endif
        report.add(name, impl, "build_ms", e.build_ms, "ms", to);
        report.add(name, impl, "cold_update_ms", e.ms.front(), "ms", to);
        report.add(name, impl, "steady_update_ms", median(steady(e.ms)), "ms", to);
        report.add(name, impl, "first_hit_rays_per_s", e.rays_per_s, "rays/s", to);
        report.add(name, impl, "brute_force_mismatches", double(e.mismatches), "rays", to);
        if (e.name == "octree") report.add(name, impl, "refit_margin", double(kOctreeRefitMargin), "box fraction");
        if (e.name == "octree" && e.mode == "refit")
            report.add(name, impl, "refit_fallbacks", double(r.octree_fallbacks), "frames");
    }
}

void print_table(const std::vector<Entrant>& es, const std::string& label, const MovingArgs& a, std::size_t threads,
                 const MovingResult& r) {
    std::ostringstream out;
    auto row = [&](const std::string& c, const std::string& b, const std::string& cold, const std::string& steady,
                   const std::string& q) {
        out << std::left << std::setw(36) << c << std::right << std::setw(11) << b << std::setw(11) << cold
            << std::setw(13) << steady << std::setw(20) << q << "\n";
    };
    auto num = [](double v) {
        std::ostringstream s;
        s << std::setprecision(4) << v;
        return s.str();
    };
    out << "\nMoving spheres: " << a.count << " spheres, " << a.frames << " frames, " << a.rays << " rays, " << threads
        << " threads (steady: median of frames 2.." << a.frames << ")\n";
    row("case", "build ms", "cold ms", "steady ms", "first hit Mrays/s");
    out << std::string(91, '-') << "\n";
    for (const Entrant& e : es)
        row(case_name(label, e), num(e.build_ms), num(e.ms.front()),
            num(median(steady(e.ms))), num(e.rays_per_s / 1e6));
    out << "octree (refit_margin " << kOctreeRefitMargin << ") refits that fell back to a rebuild: " << r.octree_fallbacks
        << " of " << a.frames
        << "; brute-force check over " << r.sample << " rays: " << r.mismatches << " mismatches\n";
    std::cout << out.str() << std::flush;
}

}  // namespace

MovingResult run_moving(const MovingArgs& a, ThreadPool& pool, Report& report, const std::string& who) {
    if (a.frames < 2) throw std::invalid_argument("moving spheres: at least 2 frames (cold and steady)");
    const std::vector<Sphere> base = make_spheres(a.count, Distribution::Uniform, 0x30F1u);
    const std::vector<Ray> rays = make_rays(a.rays, 0x30F2u);
    const std::string label = size_label(a.count) + "/uniform";
    MovingResult r;
    std::vector<Sphere> now;
    std::vector<Entrant> es = make_entrants(pool, r.octree_fallbacks);
    run_frames(es, base, now, a, pool, who);
    r.sample = std::min<std::size_t>(rays.size(), a.count > 100000 ? 200 : 1000);
    r.mismatches = check_brute_force(es, now, rays, r.sample);
    measure_queries(es, rays, pool);
    add_records(report, es, label, a, r);
    print_table(es, label, a, pool.concurrency(), r);
    return r;
}

}  // namespace bench
