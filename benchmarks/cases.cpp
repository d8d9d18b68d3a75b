// benchmarks/cases.cpp -- one benchmark case, every implementation on the same data.
#include "cases.hpp"

#include <algorithm>
#include <iostream>

#include "run_sylva.hpp"
#if SYLVA_BENCH_EMBREE
#include "run_embree.hpp"
#endif

namespace bench {

namespace {

double per_s(double count, double ms) { return count / (std::max(ms, 1e-6) / 1000.0); }

/// Runs `pass` opt.runs times; returns the last result and stores the median time in `ms`.
template <class F>
auto timed(const Options& opt, double& ms, F&& pass) {
    decltype(pass()) result;
    ms = median(samples(opt.runs, 0.0, [&] {
        result = {};
        return time_ms([&] { result = pass(); });
    }));
    return result;
}

/// The first rays of the set that a traversal case traces: all of them, or (with a pass
/// budget) as many as sylva's `probe` pass gets through in about pass_seconds, at least 1e4.
template <class F>
std::span<const sylva::Ray> ray_budget(const Context& c, F&& probe) {
    std::span<const sylva::Ray> all(c.rays);
    if (c.opt.pass_seconds <= 0.0) return all;
    auto sample = all.first(std::min<std::size_t>(all.size(), 2000));
    double ms = time_ms([&] { probe(sample); });
    double fit = static_cast<double>(sample.size()) / std::max(ms, 1e-3) * 1000.0 * c.opt.pass_seconds;
    std::size_t n = std::max(static_cast<std::size_t>(fit), std::size_t{10000});
    return all.first(std::min(n, all.size()));
}

/// Records how `got` disagrees with `ref`; fails the run when any disagreement is unexplained
/// (not a grazed sphere or a tie) or more than 1 % of the rays disagree at all. (Grazing
/// differences grow with the hits per ray: ~0.1 % of the rays at 1e7 spheres, 26 hits a ray.)
void cross_check(const Context& c, const std::string& name, const std::string& peer, std::size_t rays,
                 std::size_t disagree, std::size_t unexplained, const char* against) {
    c.report.add(name, "sylva", "disagreements", static_cast<double>(disagree), "rays", peer);
    c.report.add(name, "sylva", "unexplained_disagreements", static_cast<double>(unexplained), "rays", peer);
    if (unexplained > 0 || static_cast<double>(disagree) > 0.01 * static_cast<double>(rays))
        c.failures.push_back(name + ": " + std::to_string(disagree) + " of " + std::to_string(rays) +
                             " rays disagree with " + against + " (" + std::to_string(unexplained) +
                             " not explained by grazing or ties)");
}

void record_cost(const Context& c, const std::string& base, TraversalCost cost) {
    c.report.add(base + "/fixed16", "sylva", "nodes_per_ray", cost.nodes_per_ray, "nodes/ray");
    c.report.add(base + "/fixed16", "sylva", "leaves_per_ray", cost.leaves_per_ray, "leaves/ray");
}

void build_embree(const Context& c, const std::vector<sylva::Sphere>& spheres, const std::string& label) {
#if SYLVA_BENCH_EMBREE
    std::vector<double> setup;
    auto commit = samples(c.opt.runs, c.opt.build_budget_ms(), [&] {
        EmbreePeer::BuildTimes t = c.embree->build(spheres);
        setup.push_back(t.setup_ms);
        return t.commit_ms;
    });
    const std::string build = "build/" + label;
    double ms = median(commit);
    c.report.add(build, "embree", "build_ms", ms, "ms");
    c.report.add(build, "embree", "build_elements_per_s", per_s(static_cast<double>(spheres.size()), ms),
                 "elements/s");
    c.report.add(build, "embree", "runs", static_cast<double>(commit.size()), "runs");
    c.report.add(build, "embree", "setup_ms", median(setup), "ms");
    c.report.add(build, "embree", "bytes", static_cast<double>(c.embree->scene_bytes()), "bytes");
#else
    (void)c, (void)spheres, (void)label;
#endif
}

void first_hit(const Context& c, const SylvaIndex& idx, const std::vector<sylva::Sphere>& spheres,
               const std::string& label) {
    const std::string base = "first_hit/" + label;
    auto rays = ray_budget(c, [&](auto r) { sylva_first_hits(idx.fixed16, idx.tree, spheres, r, c.pool); });
    const double n = static_cast<double>(rays.size());
    double ms = 0.0;
    FirstHits ref;
    const char* against = "sylva fixed16";
#if SYLVA_BENCH_EMBREE
    ref = timed(c.opt, ms, [&] { return c.embree->first_hits(rays, c.pool); });
    c.report.add(base, "embree", "rays_per_s", per_s(n, ms), "rays/s");
    against = "embree";
#endif
    for (const char* fmt : {"fixed16", "float32"}) {
        const auto& words = std::string(fmt) == "fixed16" ? idx.fixed16 : idx.float32;
        FirstHits got = timed(c.opt, ms, [&] { return sylva_first_hits(words, idx.tree, spheres, rays, c.pool); });
        const std::string name = base + "/" + fmt;
        c.report.add(name, "sylva", "rays_per_s", per_s(n, ms), "rays/s", base);
        if (ref.id.empty()) ref = got;  // no peer: float32 is checked against fixed16
        cross_check(c, name, base, rays.size(), disagreements(got, ref), unexplained(got, ref, spheres, rays),
                    against);
    }
    double hit = static_cast<double>(std::count_if(ref.id.begin(), ref.id.end(), [](auto i) { return i != kNoHit; }));
    record_cost(c, base, sylva_cost(idx.fixed16, idx.tree, spheres, rays, true));
    c.report.add(base, "workload", "rays", n, "rays");
    c.report.add(base, "workload", "rays_hitting", hit / n, "fraction");
}

void all_hits(const Context& c, const SylvaIndex& idx, const std::vector<sylva::Sphere>& spheres,
              const std::string& label) {
    const std::string base = "all_hits/" + label;
    auto rays = ray_budget(c, [&](auto r) { sylva_all_hits(idx.fixed16, idx.tree, spheres, r, c.pool); });
    const double n = static_cast<double>(rays.size());
    double ms = 0.0;
    AllHits ref;
    HitList ref_list = sylva_hit_list(idx.fixed16, idx.tree, spheres);
    const char* against = "sylva fixed16";
#if SYLVA_BENCH_EMBREE
    ref = timed(c.opt, ms, [&] { return c.embree->all_hits(rays, c.pool); });
    c.report.add(base, "embree", "rays_per_s", per_s(n, ms), "rays/s");
    ref_list = c.embree->hit_list();
    against = "embree";
#endif
    for (const char* fmt : {"fixed16", "float32"}) {
        const auto& words = std::string(fmt) == "fixed16" ? idx.fixed16 : idx.float32;
        AllHits got = timed(c.opt, ms, [&] { return sylva_all_hits(words, idx.tree, spheres, rays, c.pool); });
        const std::string name = base + "/" + fmt;
        c.report.add(name, "sylva", "rays_per_s", per_s(n, ms), "rays/s", base);
        if (ref.count.empty()) ref = got;
        std::size_t bad = unexplained(got, ref, spheres, rays, sylva_hit_list(words, idx.tree, spheres), ref_list);
        cross_check(c, name, base, rays.size(), disagreements(got, ref), bad, against);
    }
    double hits = 0.0;
    for (auto k : ref.count) hits += k;
    record_cost(c, base, sylva_cost(idx.fixed16, idx.tree, spheres, rays, false));
    c.report.add(base, "workload", "rays", n, "rays");
    c.report.add(base, "workload", "mean_hits", hits / n, "hits/ray");
}

}  // namespace

void run_case(const Context& c, std::size_t n, Distribution d, bool stream) {
    const std::string label = size_label(n) + "/" + name(d);
    std::cerr << "sylva-bench: " << label << " ..." << std::endl;
    std::vector<sylva::Sphere> spheres = make_spheres(n, d, static_cast<std::uint32_t>(n) ^ 0x5EEDu);
    SylvaIndex idx = bench_sylva_build(spheres, c.pool, c.opt, c.report, label);
    build_embree(c, spheres, label);
    first_hit(c, idx, spheres, label);
    all_hits(c, idx, spheres, label);
    if (stream)
        c.report.add("stream/" + label + "/fixed16", "memory", "bandwidth_GB_per_s",
                     stream_gb_per_s(idx.fixed16, c.pool, c.opt.runs), "GB/s");
}

}  // namespace bench
