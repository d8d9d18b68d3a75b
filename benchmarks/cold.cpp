// benchmarks/cold.cpp -- cold first builds, each in a fresh process (issue 15, item 2).
//
// A builder's first build in a process pays for the first touch of every page it writes: on a
// new virtual machine that is ~3 ms per MB (the hypervisor maps pages on first use), on a
// machine whose memory has been in use for hours a page fault and a zeroing, and in a process
// that has built before, nothing. The steady-state medians of the build race only ever see the
// last. So each builder is also timed in `--cold-runs` fresh processes of this executable
// (`--cold-child IMPL`), one first build each; the parent records the median as build_cold_ms.
// Before the timed build the child builds once over 64 spheres: threads started (sylva's pool,
// TBB's workers under Embree), code paged in, per-thread state set up, so that what is left is
// the memory. On this machine the children run on memory the kernel has handed out before, so
// the cold figures are a lower bound of what a fresh machine shows.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sylva/bih/wide.hpp>

#include "cases.hpp"
#include "processes.hpp"
#include "run_sylva.hpp"
#if SYLVA_BENCH_EMBREE
#include "run_embree.hpp"
#endif

namespace bench {

namespace {

/// One builder a cold child can run, and where its records go.
struct ColdBuilder {
    const char* impl;    ///< --cold-child's value
    const char* suffix;  ///< appended to "build/<label>" for its case name
    const char* config;  ///< the sylva configuration ("" for embree)
};

constexpr ColdBuilder kColdBuilders[] = {
    {"default", "", "fixed16"},        {"leaf4", "/leaf4", "fixed16-leaf4"}, {"query", "/query", "fixed16-query"},
    {"wide", "/wide", "wide"},         {"octree", "/octree", "octree"},      {"kd", "/kd", "kd"},
#if SYLVA_BENCH_EMBREE
    {"embree", "", ""},
#endif
};

/// Builds `spheres` once with `impl` and returns the milliseconds the build took (as the build
/// race times it: sylva's builder call; Embree's rtcCommitScene; the wide tree: the build of its
/// BIH (bih::wide_source_config) plus the collapse).
double time_one_build(const std::string& impl, const std::vector<sylva::Sphere>& spheres, sylva::ThreadPool& pool) {
    if (impl == "default" || impl == "leaf4" || impl == "query") {
        TreeKind kind = impl == "default" ? TreeKind::Default : impl == "leaf4" ? TreeKind::Leaf4 : TreeKind::Query;
        sylva::bih::Tree tree;
        return time_sylva_build(tree, spheres, kind, pool);
    }
    if (impl == "wide") {
        sylva::bih::Tree tree;
        double ms = time_sylva_build(tree, spheres, TreeKind::Wide, pool);
        return ms + time_ms([&] {
                   sylva::bih::WideTree<sylva::Sphere> wide(tree, std::span<const sylva::Sphere>(spheres),
                                                            sylva::bih::WideConfig{}, pool);
                   if (wide.stats().nodes == 0) throw std::runtime_error("cold child: empty wide tree");
               });
    }
    if (impl == "octree") {
        sylva::octree::ElementTree tree;
        return time_octree_build(tree, spheres, pool);
    }
    if (impl == "kd") {
        sylva::kdtree::ElementTree tree;
        return time_kd_build(tree, spheres, pool);
    }
    throw std::invalid_argument("cold child: no builder '" + impl + "'");
}

/// Reads the child's "cold_build_ms X" line.
double read_cold_ms(const std::string& out, const std::string& what) {
    std::size_t at = out.find("cold_build_ms ");
    double ms = -1.0;
    if (at != std::string::npos) ms = std::strtod(out.c_str() + at + 14, nullptr);
    if (!(ms >= 0.0)) throw std::runtime_error(what + " printed no cold_build_ms: '" + out + "'");
    return ms;
}

}  // namespace

int cold_child_main(const Options& opt) {
    if (opt.sizes.size() != 1) throw std::invalid_argument("--cold-child takes one size in --sizes");
    std::size_t n = opt.sizes.front();
    Distribution d = opt.cold_distribution == "clustered" ? Distribution::Clustered : Distribution::Uniform;
    sylva::ThreadPool pool(opt.threads);
    std::vector<sylva::Sphere> spheres = make_spheres(n, d, sphere_seed(n));
    std::vector<sylva::Sphere> warm = make_spheres(64, d, 1u);
    double ms = 0.0;
    if (opt.cold_child == "embree") {
#if SYLVA_BENCH_EMBREE
        EmbreePeer embree(pool.concurrency());
        embree.build(warm);
        settle();
        ms = embree.build(spheres).commit_ms;
#else
        throw std::invalid_argument("--cold-child embree: built without Embree");
#endif
    } else {
        time_one_build(opt.cold_child, warm, pool);
        settle();
        ms = time_one_build(opt.cold_child, spheres, pool);
    }
    std::printf("cold_build_ms %.6f\n", ms);
    return 0;
}

void cold_builds(const Context& c, std::size_t n, Distribution d, const std::string& label) {
    if (c.opt.cold_runs == 0) return;
    const std::string exe = self_executable();
    const std::string build = "build/" + label;
    constexpr std::size_t kCount = std::size(kColdBuilders);
    std::vector<double> ms[kCount];
    auto child_args = [&](const ColdBuilder& b) {
        return std::vector<std::string>{"--cold-child", b.impl, "--sizes", std::to_string(n), "--cold-distribution",
                                        name(d), "--threads", std::to_string(c.pool.concurrency())};
    };
    // One untimed child first, of the default tree (the builder that touches the most memory):
    // the first child after the parent's own work pays for memory the kernel has to get back
    // (10^7 spheres: this warm-up child 4,241 ms, the timed default children's median 2,581;
    // after a full run, five default children at 10^4: 34, 12, 2.1, 2.1, 2.1 ms), and the
    // alternating order of the rounds below puts one builder first twice in three rounds. Its
    // time is reported (cold_warmup_ms), not counted.
    const double warmup = read_cold_ms(run_child(exe, child_args(kColdBuilders[0])), "cold warm-up child");
    c.report.add(build, "sylva", "cold_warmup_ms", warmup, "ms", "", kColdBuilders[0].config);
    for (std::size_t r = 0; r < c.opt.cold_runs; ++r)
        for (std::size_t i = 0; i < kCount; ++i) {
            const ColdBuilder& b = kColdBuilders[r % 2 == 0 ? i : kCount - 1 - i];  // as the build race
            const std::string what = std::string("cold child ") + b.impl;
            ms[&b - kColdBuilders].push_back(read_cold_ms(run_child(exe, child_args(b)), what));
        }
    for (std::size_t i = 0; i < kCount; ++i) {
        const ColdBuilder& b = kColdBuilders[i];
        bool embree = std::string(b.impl) == "embree";
        const std::string name = build + b.suffix, impl = embree ? "embree" : "sylva", peer = embree ? "" : build;
        double m = median(ms[i]);
        c.report.add(name, impl, "build_cold_ms", m, "ms", peer, b.config);
        c.report.add(name, impl, "build_cold_elements_per_s", per_s(static_cast<double>(n), m), "elements/s", peer,
                     b.config);
    }
}

}  // namespace bench
