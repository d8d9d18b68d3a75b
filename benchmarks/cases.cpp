// benchmarks/cases.cpp -- one benchmark case, every implementation on the same data.
#include "cases.hpp"

#include <algorithm>
#include <functional>
#include <iostream>

#include "run_sylva.hpp"
#if SYLVA_BENCH_EMBREE
#include "run_embree.hpp"
#endif

namespace bench {

namespace {

/// One implementation's pass in a race: its case, the pass, its last result and its times.
template <class R>
struct Entrant {
    std::string impl;
    std::string case_name;
    std::function<void(R&)> pass;  ///< one pass into a prepare()d result
    const Variant* variant = nullptr;  ///< null for embree
    R result{};
    std::vector<double> ms{};
};

/// Runs every entrant's pass opt.runs times, interleaved (run r of each before run r + 1 of
/// any), so that load from elsewhere on the machine hits all of them alike; records rays/s: the
/// steady state (the median of the passes after the first) and the first pass in the process.
/// Each pass writes into its entrant's result, sized and filled before the clock starts (see
/// FirstHits).
template <class R>
void race(const Context& c, std::vector<Entrant<R>>& entrants, const std::string& base, std::size_t rays) {
    for (std::size_t r = 0; r < c.opt.runs; ++r)
        for (auto& e : entrants) {
            e.result.prepare(rays);
            settle();
            e.ms.push_back(time_ms([&] { e.pass(e.result); }));
        }
    for (auto& e : entrants) {
        const std::string peer = e.impl == "embree" ? "" : base, config = e.variant ? e.variant->name : "";
        const double count = static_cast<double>(rays);
        c.report.add(e.case_name, e.impl, "rays_per_s", per_s(count, median(steady(e.ms))), "rays/s", peer, config);
        c.report.add(e.case_name, e.impl, "rays_per_s_first_pass", per_s(count, e.ms.front()), "rays/s", peer, config);
    }
}

/// The rays ray_budget times its probe pass on (the first ones of the set, at most this many).
constexpr std::size_t kBudgetSample = 2000;

/// The first rays of the set that a traversal case traces: all of them, or (with a pass
/// budget) as many as sylva's `probe` pass gets through in about pass_seconds, at least 1e4.
template <class F>
std::span<const sylva::Ray> ray_budget(const Context& c, F&& probe) {
    std::span<const sylva::Ray> all(c.rays);
    if (c.opt.pass_seconds <= 0.0) return all;
    auto sample = all.first(std::min(all.size(), kBudgetSample));
    double ms = time_ms([&] { probe(sample); });
    double fit = static_cast<double>(sample.size()) / std::max(ms, 1e-3) * 1000.0 * c.opt.pass_seconds;
    std::size_t n = std::max(static_cast<std::size_t>(fit), std::size_t{10000});
    return all.first(std::min(n, all.size()));
}

/// Records how `got` disagrees with `ref`; fails the run when any disagreement is unexplained
/// (not a grazed sphere or a tie) or more than 1 % of the rays disagree at all. (Grazing
/// differences grow with the hits per ray: ~0.1 % of the rays at 1e7 spheres, 26 hits a ray.)
void cross_check(const Context& c, const std::string& name, const std::string& peer, std::size_t rays,
                 std::size_t disagree, std::size_t unexplained, const char* against, const std::string& config) {
    c.report.add(name, "sylva", "disagreements", static_cast<double>(disagree), "rays", peer, config);
    c.report.add(name, "sylva", "unexplained_disagreements", static_cast<double>(unexplained), "rays", peer, config);
    if (unexplained > 0 || static_cast<double>(disagree) > 0.01 * static_cast<double>(rays))
        c.failures.push_back(name + ": " + std::to_string(disagree) + " of " + std::to_string(rays) +
                             " rays disagree with " + against + " (" + std::to_string(unexplained) +
                             " not explained by grazing or ties)");
}

void record_cost(const Context& c, const std::string& name, TraversalCost cost, const std::string& config) {
    c.report.add(name, "sylva", "nodes_per_ray", cost.nodes_per_ray, "nodes/ray", "", config);
    c.report.add(name, "sylva", "leaves_per_ray", cost.leaves_per_ray, "leaves/ray", "", config);
}

/// One implementation's build in the build race: run() builds once and returns the ms it timed.
struct Builder {
    std::function<double()> run;
    std::vector<double> ms{};
    double total = 0.0;
};

/// Runs each builder opt.build_runs() times, interleaved, until one of them has spent the build
/// budget.
/// Odd runs go in reverse order, so that no builder always follows the same one: a build right
/// after Embree's shares the cores with TBB's workers, which spin for a while after a commit
/// (at 10^4 spheres that cost the next build about 0.5 ms of 1.2-1.8 ms). Each build also starts
/// after settle(), when those workers (and sylva::ThreadPool's polling ones) are asleep.
void build_race(const Context& c, std::vector<Builder>& builders) {
    for (std::size_t r = 0; r < c.opt.build_runs(); ++r) {
        bool spent = false;
        for (std::size_t k = 0; k < builders.size(); ++k) {
            Builder& b = builders[r % 2 == 0 ? k : builders.size() - 1 - k];
            settle();
            b.ms.push_back(b.run());
            b.total += b.ms.back();
            spent = spent || (c.opt.build_budget_ms() > 0.0 && b.total >= c.opt.build_budget_ms());
        }
        if (spent) break;
    }
}

void record_embree_build(const Context& c, const Builder& b, const std::vector<double>& setup, std::size_t n,
                         const std::string& build) {
#if SYLVA_BENCH_EMBREE
    const std::vector<double> runs = steady(b.ms);
    double ms = median(runs);
    c.report.add(build, "embree", "build_ms", ms, "ms");
    c.report.add(build, "embree", "build_elements_per_s", per_s(static_cast<double>(n), ms), "elements/s");
    c.report.add(build, "embree", "runs", static_cast<double>(runs.size()), "runs");
    c.report.add(build, "embree", "setup_ms", median(steady(setup)), "ms");
    c.report.add(build, "embree", "bytes", static_cast<double>(c.embree->scene_bytes()), "bytes");
#else
    (void)c, (void)b, (void)setup, (void)n, (void)build;
#endif
}

/// Builds the default, leaf4 and query BIHs, the element octree and kd-tree, the BIH the wide
/// tree is collapsed from and the Embree scene, interleaved; then the encodings.
SylvaIndex build_all(const Context& c, const std::vector<sylva::Sphere>& spheres, const std::string& label) {
    SylvaIndex idx;
    std::vector<double> setup;
    std::vector<Builder> bs;
    bs.push_back({[&] { return time_sylva_build(idx.tree, spheres, TreeKind::Default, c.pool); }});
    bs.push_back({[&] { return time_sylva_build(idx.leaf4_tree, spheres, TreeKind::Leaf4, c.pool); }});
    // The wide tree's BIH runs among the other BIH builds, which free blocks of the sizes it asks
    // for (its records), as its own previous build would in a program that rebuilds: placed
    // after the kd build instead, it took 5.8-6.0 ms at 10^5 spheres against 4.5-4.7 here (the
    // allocator's cache then holds other sizes; README, "Shared machinery").
    bs.push_back({[&] { return time_sylva_build(idx.wide_tree, spheres, TreeKind::Wide, c.pool); }});
    bs.push_back({[&] { return time_sylva_build(idx.query_tree, spheres, TreeKind::Query, c.pool); }});
    bs.push_back({[&] { return time_octree_build(idx.octree_tree, spheres, c.pool); }});
    bs.push_back({[&] { return time_kd_build(idx.kd_tree, spheres, c.pool); }});
#if SYLVA_BENCH_EMBREE
    bs.push_back({[&] {
        EmbreePeer::BuildTimes t = c.embree->build(spheres);
        setup.push_back(t.setup_ms);
        return t.commit_ms;
    }});
#endif
    build_race(c, bs);
    const std::string build = "build/" + label;
    // The steady state: the runs after each builder's first in this process (cold.cpp times
    // first builds in fresh processes).
    record_sylva_build(c.report, build, build, steady(bs[0].ms), idx.tree, "fixed16");
    record_sylva_build(c.report, build + "/leaf4", build, steady(bs[1].ms), idx.leaf4_tree, "fixed16-leaf4");
    record_sylva_build(c.report, build + "/query", build, steady(bs[3].ms), idx.query_tree, "fixed16-query");
    record_octree_build(c.report, build + "/octree", build, steady(bs[4].ms), idx.octree_tree);
    record_kd_build(c.report, build + "/kd", build, steady(bs[5].ms), idx.kd_tree);
    if (bs.size() > 6) record_embree_build(c, bs[6], setup, spheres.size(), build);
    bench_sylva_encode(idx, spheres, c.opt, c.report, label, c.pool);
    // The wide tree's whole build: the BIH it collapses (wide_source_config: leaves of the wide
    // tree's leaf size) plus the collapse (medians), as bih::build_wide runs them.
    const double source_ms = median(steady(bs[2].ms)), collapse_ms = median(steady(idx.wide_ms));
    const double wide_ms = source_ms + collapse_ms;
    c.report.add(build + "/wide", "sylva", "build_ms", wide_ms, "ms", build, "wide");
    c.report.add(build + "/wide", "sylva", "source_build_ms", source_ms, "ms", "", "wide");
    c.report.add(build + "/wide", "sylva", "collapse_ms", collapse_ms, "ms", "", "wide");
    c.report.add(build + "/wide", "sylva", "build_elements_per_s", per_s(static_cast<double>(spheres.size()), wide_ms),
                 "elements/s", build, "wide");
    return idx;
}

/// The entrants of a traversal case: embree (when built with it), then each sylva variant.
/// The first entrant is the reference the others are checked against.
template <class R, class S, class E>
std::vector<Entrant<R>> entrants(const Context& c, const std::vector<Variant>& vs, const std::string& base,
                                 S&& sylva_pass, E&& embree_pass) {
    std::vector<Entrant<R>> out;
#if SYLVA_BENCH_EMBREE
    out.push_back({"embree", base, [&c, embree_pass](R& r) { embree_pass(*c.embree, r); }});
#else
    (void)c, (void)embree_pass;
#endif
    for (const Variant& v : vs)
        out.push_back({"sylva", base + "/" + v.name, [&v, sylva_pass](R& r) { sylva_pass(v, r); }, &v});
    return out;
}

void first_hit(const Context& c, const SylvaIndex& idx, const std::vector<sylva::Sphere>& spheres,
               const std::string& label) {
    const std::string base = "first_hit/" + label;
    const std::vector<Variant> vs = variants(idx);
    FirstHits probe;
    probe.prepare(std::min(c.rays.size(), kBudgetSample));
    auto rays = ray_budget(c, [&](auto r) { sylva_first_hits(vs[0], spheres, r, c.pool, probe); });
    auto es = entrants<FirstHits>(
        c, vs, base, [&](const Variant& v, FirstHits& out) { sylva_first_hits(v, spheres, rays, c.pool, out); },
        [&](const auto& peer, FirstHits& out) { peer.first_hits(rays, c.pool, out); });
    race(c, es, base, rays.size());
    const FirstHits& ref = es.front().result;
    std::string against = es.front().impl == "embree" ? "embree" : "sylva fixed16";
    for (std::size_t i = 1; i < es.size(); ++i)
        cross_check(c, es[i].case_name, base, rays.size(), disagreements(es[i].result, ref),
                    unexplained(es[i].result, ref, spheres, rays), against.c_str(), es[i].variant->name);
    auto hit = std::count_if(ref.id.begin(), ref.id.end(), [](auto i) { return i != kNoHit; });
    for (const Variant& v : vs) record_cost(c, base + "/" + v.name, sylva_cost(v, spheres, rays, true), v.name);
    c.report.add(base, "workload", "rays", static_cast<double>(rays.size()), "rays");
    c.report.add(base, "workload", "rays_hitting", static_cast<double>(hit) / static_cast<double>(rays.size()),
                 "fraction");
}

void all_hits(const Context& c, const SylvaIndex& idx, const std::vector<sylva::Sphere>& spheres,
              const std::string& label) {
    const std::string base = "all_hits/" + label;
    const std::vector<Variant> vs = variants(idx);
    AllHits probe;
    probe.prepare(std::min(c.rays.size(), kBudgetSample));
    auto rays = ray_budget(c, [&](auto r) { sylva_all_hits(vs[0], spheres, r, c.pool, probe); });
    auto es = entrants<AllHits>(
        c, vs, base, [&](const Variant& v, AllHits& out) { sylva_all_hits(v, spheres, rays, c.pool, out); },
        [&](const auto& peer, AllHits& out) { peer.all_hits(rays, c.pool, out); });
    race(c, es, base, rays.size());
    const AllHits& ref = es.front().result;
    HitList ref_list = sylva_hit_list(vs[0], spheres);
    std::string against = "sylva fixed16";
#if SYLVA_BENCH_EMBREE
    ref_list = c.embree->hit_list();
    against = "embree";
#endif
    for (std::size_t i = 1; i < es.size(); ++i) {
        const Entrant<AllHits>& e = es[i];
        std::size_t bad = unexplained(e.result, ref, spheres, rays, sylva_hit_list(*e.variant, spheres), ref_list);
        cross_check(c, e.case_name, base, rays.size(), disagreements(e.result, ref), bad, against.c_str(), e.variant->name);
    }
    double hits = 0.0;
    for (auto k : ref.count) hits += k;
    for (const Variant& v : vs) record_cost(c, base + "/" + v.name, sylva_cost(v, spheres, rays, false), v.name);
    c.report.add(base, "workload", "rays", static_cast<double>(rays.size()), "rays");
    c.report.add(base, "workload", "mean_hits", hits / static_cast<double>(rays.size()), "hits/ray");
}

}  // namespace

void run_case(const Context& c, std::size_t n, Distribution d, bool stream, bool loaded) {
    const std::string label = (loaded ? "load/" : "") + size_label(n) + "/" + name(d);
    std::cerr << "sylva-bench: " << label << " ..." << std::endl;
    if (!loaded) cold_builds(c, n, d, label);
    std::vector<sylva::Sphere> spheres = make_spheres(n, d, sphere_seed(n));
    SylvaIndex idx = build_all(c, spheres, label);
    if (c.opt.run_first) first_hit(c, idx, spheres, label);
    if (c.opt.run_all) all_hits(c, idx, spheres, label);
    if (stream)
        c.report.add("stream/" + label + "/fixed16", "memory", "bandwidth_GB_per_s",
                     stream_gb_per_s(idx.fixed16, c.pool, c.opt.runs), "GB/s");
}

}  // namespace bench
