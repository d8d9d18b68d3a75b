// benchmarks/run_sylva.cpp -- sylva's side of each case.
#include "run_sylva.hpp"

#include <atomic>
#include <limits>
#include <span>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/shared/kd_elem_iter.h>
#include <sylva/shared/octree_elem_iter.h>

namespace bench {

namespace bih = sylva::bih;
using sylva::Sphere;

namespace {

volatile std::uint64_t g_sink = 0;

/// Times one encoder configuration; records encode_ms and bytes; returns the last encoding.
template <class P>
std::vector<std::uint32_t> time_encode(const bih::Tree& tree, std::span<const Sphere> es, const P& payload,
                                       bih::NodeFormat format, const std::string& name, const Options& opt,
                                       Report& report, const std::string& config, sylva::ThreadPool& pool) {
    std::vector<std::uint32_t> words;
    const bih::EncodeConfig cfg{format, bih::Layout::TreeChunks, 2};
    auto ms_all = samples(opt.runs, opt.encode_budget_ms(), [&] {
        words = {};
        return time_ms([&] { words = bih::encode(tree, es, payload, cfg, pool); });
    });
    const std::vector<double> runs = steady(ms_all);
    double ms = median(runs);
    report.add(name, "sylva", "encode_ms", ms, "ms", "", config);
    report.add(name, "sylva", "runs", static_cast<double>(runs.size()), "runs", "", config);
    report.add(name, "sylva", "encode_nodes_per_s", per_s(static_cast<double>(tree.nodes.size()), ms), "nodes/s", "",
               config);
    report.add(name, "sylva", "bytes", static_cast<double>(bih::encoded_bytes(words)), "bytes", "", config);
    return words;
}

/// The element octree's walk steps (nodes entered) and leaves with references per ray; first
/// hit: ending the walk at the end of the leaf where octree::first_hit's answer becomes final.
TraversalCost octree_cost(const std::vector<std::uint32_t>& words, const std::vector<Sphere>& spheres,
                          std::span<const sylva::Ray> rays, bool first) {
    namespace sh = sylva::shared;
    sh::Words w{words.data(), words.size()};
    double steps = 0.0, leaves = 0.0;
    for (const sylva::Ray& ray : rays) {
        sh::SylvaOctElemIter it;
        sh::sylva_octe_init(it, w, static_cast<std::uint32_t>(words.size()), ray.origin, ray.direction, 0.0f, sh::sylva_inf());
        std::uint32_t node, at, count;
        float t0, t1, best = std::numeric_limits<float>::infinity();
        while (sh::sylva_octe_next(it, w, node, t0, t1, at, count)) {
            leaves += 1.0;
            if (!first) continue;
            for (std::uint32_t k = 0; k < count; ++k) {
                auto t = sylva::intersect_element(spheres[words[at + k]], ray, sylva::Interval{});
                if (t && t->t0 < best) best = t->t0;
            }
            if (best < t1) break;
        }
        steps += it.walk.steps;
    }
    double n = static_cast<double>(std::max<std::size_t>(rays.size(), 1));
    return {steps / n, leaves / n};
}

/// The element kd-tree's nodes visited and leaves with references per ray (first hit: ending
/// where kdtree::first_hit's answer becomes final).
TraversalCost kd_cost(const std::vector<std::uint32_t>& words, const std::vector<Sphere>& spheres,
                      std::span<const sylva::Ray> rays, bool first) {
    namespace sh = sylva::shared;
    sh::Words w{words.data(), words.size()};
    double steps = 0.0, leaves = 0.0;
    for (const sylva::Ray& ray : rays) {
        sh::SylvaKdElemIter it;
        sh::sylva_kde_init(it, w, static_cast<std::uint32_t>(words.size()), ray.origin, ray.direction, 0.0f, sh::sylva_inf());
        std::uint32_t node, at, count;
        float t0, t1, best = std::numeric_limits<float>::infinity();
        while (sh::sylva_kde_next(it, w, node, t0, t1, at, count)) {
            leaves += 1.0;
            if (!first) continue;
            for (std::uint32_t k = 0; k < count; ++k) {
                auto t = sylva::intersect_element(spheres[words[at + k]], ray, sylva::Interval{});
                if (t && t->t0 < best) best = t->t0;
            }
            if (best < t1) break;
        }
        steps += it.steps;
    }
    double n = static_cast<double>(std::max<std::size_t>(rays.size(), 1));
    return {steps / n, leaves / n};
}

}  // namespace

void describe_configs(Report& report) {
    report.describe("fixed16", "bih::Config{} (1 sphere a leaf, trimmed, trim-both); EncodeConfig{Fixed16, TreeChunks, 2}, "
                               "RangePayload; bih::first_hit / all_hits(words, tree, spheres) (elements via tree.order)");
    report.describe("float32", "as fixed16 with NodeFormat::Float32");
    report.describe("fixed16-leaf4", "bih::Config{max_leaf_elements = 4, trim_leaves = false}; otherwise as fixed16");
    report.describe("wide", "bih::WideTree (WideConfig{}: 8-wide nodes, refitted boxes, leaves of up to 4 spheres, 8 "
                            "above 2^15 spheres, in packets of four) collapsed from the BIH of bih::wide_source_config "
                            "(leaves of that size, untrimmed), as bih::build_wide makes it; bih::first_hit / "
                            "all_hits(wide); its build time is that BIH's build plus the collapse (encode/.../wide)");
    report.describe("fixed16-query", "bih::Config::for_queries() (up to 32 spheres a leaf, untrimmed); EncodeConfig{Fixed16, "
                             "TreeChunks, 2}, RangePayload; bih::LeafRecords (spheres in leaf order, 16-byte records, "
                             "tested four at a time); bih::first_hit / all_hits(words, records)");
    report.describe("octree", "octree::build_elements(spheres, ElementConfig{}) (issue 12: Gobbetti's node encoding with "
                              "neighbour pointers, straddling references, leaves of 8, max_growth 3) over the spheres "
                              "in their order; octree::encode_elements; octree::first_hit / all_hits(words, spheres) "
                              "(the stackless neighbour-pointer walk of sylva/shared/octree_elem_iter.h)");
    report.describe("kd", "kdtree::build_elements(spheres, ElementConfig{}) (issue 14: binned SAH, 32 bins, straddling "
                          "references, leaves of <= 8 or where the SAH stops) over the spheres in their order; "
                          "kdtree::encode_elements; kdtree::first_hit / all_hits(words, spheres) (the stack walk of "
                          "sylva/shared/kd_elem_iter.h, exact order by claims)");
}

double time_kd_build(sylva::kdtree::ElementTree& out, const std::vector<Sphere>& spheres, sylva::ThreadPool& pool) {
    out = {};
    return time_ms([&] { out = sylva::kdtree::build_elements(std::span<const Sphere>(spheres), {}, pool); });
}

void record_kd_build(Report& report, const std::string& name, const std::string& peer, const std::vector<double>& ms,
                     const sylva::kdtree::ElementTree& tree) {
    double b = median(ms);
    double n = static_cast<double>(tree.element_count);
    report.add(name, "sylva", "build_ms", b, "ms", peer, "kd");
    report.add(name, "sylva", "build_elements_per_s", per_s(n, b), "elements/s", peer, "kd");
    report.add(name, "sylva", "runs", static_cast<double>(ms.size()), "runs", peer, "kd");
    report.add(name, "sylva", "nodes", static_cast<double>(tree.nodes.size()), "nodes", "", "kd");
    report.add(name, "sylva", "max_depth", static_cast<double>(tree.depth), "levels", "", "kd");
    report.add(name, "sylva", "references_per_element", static_cast<double>(tree.refs.size()) / std::max(n, 1.0), "refs",
               "", "kd");
}

double time_octree_build(sylva::octree::ElementTree& out, const std::vector<Sphere>& spheres, sylva::ThreadPool& pool) {
    out = {};
    return time_ms([&] { out = sylva::octree::build_elements(std::span<const Sphere>(spheres), {}, pool); });
}

void record_octree_build(Report& report, const std::string& name, const std::string& peer, const std::vector<double>& ms,
                         const sylva::octree::ElementTree& tree) {
    double b = median(ms);
    double n = static_cast<double>(tree.element_count);
    report.add(name, "sylva", "build_ms", b, "ms", peer, "octree");
    report.add(name, "sylva", "build_elements_per_s", per_s(n, b), "elements/s", peer, "octree");
    report.add(name, "sylva", "runs", static_cast<double>(ms.size()), "runs", peer, "octree");
    report.add(name, "sylva", "nodes", static_cast<double>(tree.tree.nodes.size()), "nodes", "", "octree");
    std::uint32_t depth = 0;
    for (const sylva::octree::Node& node : tree.tree.nodes) depth = std::max(depth, node.level);
    report.add(name, "sylva", "max_depth", static_cast<double>(depth), "levels", "", "octree");
    report.add(name, "sylva", "references_per_element", static_cast<double>(tree.refs.size()) / std::max(n, 1.0), "refs",
               "", "octree");
}

double time_sylva_build(bih::Tree& out, const std::vector<Sphere>& spheres, TreeKind kind, sylva::ThreadPool& pool) {
    bih::Config cfg;
    if (kind == TreeKind::Leaf4) {
        cfg.max_leaf_elements = 4;
        cfg.trim_leaves = false;
    }
    if (kind == TreeKind::Query) cfg = bih::Config::for_queries();
    if (kind == TreeKind::Wide) cfg = bih::wide_source_config(spheres.size());
    out = {};
    return time_ms([&] { out = bih::build(std::span<const Sphere>(spheres), cfg, pool); });
}

void record_sylva_build(Report& report, const std::string& name, const std::string& peer, const std::vector<double>& ms,
                        const bih::Tree& tree, const std::string& config) {
    double b = median(ms);
    const bih::BuildStats& st = tree.stats;
    report.add(name, "sylva", "build_ms", b, "ms", peer, config);
    report.add(name, "sylva", "build_elements_per_s", per_s(static_cast<double>(st.elements), b), "elements/s", peer,
               config);
    report.add(name, "sylva", "runs", static_cast<double>(ms.size()), "runs", peer, config);
    report.add(name, "sylva", "nodes", static_cast<double>(st.nodes), "nodes", "", config);
    report.add(name, "sylva", "max_depth", st.max_depth, "levels", "", config);
    report.add(name, "sylva", "single_child_percent", st.percent_single_child(), "%", "", config);
}

void bench_sylva_encode(SylvaIndex& idx, const std::vector<Sphere>& spheres, const Options& opt, Report& report,
                        const std::string& label, sylva::ThreadPool& pool) {
    std::span<const Sphere> es(spheres);
    const std::string build = "build/" + label, enc = "encode/" + label;
    idx.fixed16 = time_encode(idx.tree, es, bih::RangePayload{}, bih::NodeFormat::Fixed16, enc + "/fixed16-range", opt,
                              report, "fixed16", pool);
    idx.float32 = time_encode(idx.tree, es, bih::RangePayload{}, bih::NodeFormat::Float32, enc + "/float32-range", opt,
                              report, "float32", pool);
    time_encode(idx.tree, es, sylva::ParticlePayload{}, bih::NodeFormat::Fixed16, enc + "/fixed16-particle", opt,
                report, "fixed16", pool);
    idx.leaf4 = bih::encode(idx.leaf4_tree, es, bih::RangePayload{}, {}, pool);
    idx.query = time_encode(idx.query_tree, es, bih::RangePayload{}, bih::NodeFormat::Fixed16, enc + "/fixed16-query",
                            opt, report, "fixed16-query", pool);
    auto ms = samples(opt.runs, opt.encode_budget_ms(), [&] {
        idx.query_records = {};
        return time_ms([&] { idx.query_records = bih::LeafRecords<Sphere>(idx.query_tree, es, pool); });
    });
    report.add(enc + "/fixed16-query-records", "sylva", "encode_ms", median(steady(ms)), "ms", "", "fixed16-query");
    report.add(enc + "/fixed16-query-records", "sylva", "bytes",
               static_cast<double>(idx.query_records.records().size_bytes() + idx.query_records.ids().size_bytes()),
               "bytes", "", "fixed16-query");
    idx.wide_ms = samples(opt.runs, opt.encode_budget_ms(), [&] {
        idx.wide = {};
        return time_ms([&] { idx.wide = bih::WideTree<Sphere>(idx.wide_tree, es, bih::WideConfig{}, pool); });
    });
    report.add(enc + "/wide", "sylva", "encode_ms", median(steady(idx.wide_ms)), "ms", "", "wide");
    report.add(enc + "/wide", "sylva", "bytes", static_cast<double>(idx.wide.stats().bytes), "bytes", "", "wide");
    report.add(enc + "/wide", "sylva", "wide_nodes", static_cast<double>(idx.wide.stats().nodes), "nodes", "", "wide");
    report.add(enc + "/wide", "sylva", "wide_leaves", static_cast<double>(idx.wide.stats().leaves), "leaves", "",
               "wide");
    auto oct_ms = samples(opt.runs, opt.encode_budget_ms(), [&] {
        idx.octree = {};
        return time_ms([&] { idx.octree = sylva::octree::encode_elements(idx.octree_tree); });
    });
    report.add(enc + "/octree", "sylva", "encode_ms", median(steady(oct_ms)), "ms", "", "octree");
    report.add(build + "/octree", "sylva", "bytes", static_cast<double>(idx.octree.size() * 4), "bytes", build, "octree");
    auto kd_ms = samples(opt.runs, opt.encode_budget_ms(), [&] {
        idx.kd = {};
        return time_ms([&] { idx.kd = sylva::kdtree::encode_elements(idx.kd_tree); });
    });
    report.add(enc + "/kd", "sylva", "encode_ms", median(steady(kd_ms)), "ms", "", "kd");
    report.add(build + "/kd", "sylva", "bytes", static_cast<double>(idx.kd.size() * 4), "bytes", build, "kd");
    report.add(build, "sylva", "bytes", static_cast<double>(bih::encoded_bytes(idx.fixed16)), "bytes", build, "fixed16");
    report.add(build + "/leaf4", "sylva", "bytes", static_cast<double>(bih::encoded_bytes(idx.leaf4)), "bytes", build,
               "fixed16-leaf4");
    report.add(build + "/query", "sylva", "bytes", static_cast<double>(bih::encoded_bytes(idx.query)), "bytes", build,
               "fixed16-query");
}

std::vector<Variant> variants(const SylvaIndex& idx) {
    return {{"fixed16", &idx.tree, &idx.fixed16},
            {"float32", &idx.tree, &idx.float32},
            {"fixed16-leaf4", &idx.leaf4_tree, &idx.leaf4},
            {"fixed16-query", &idx.query_tree, &idx.query, &idx.query_records},
            {"wide", &idx.leaf4_tree, &idx.leaf4, nullptr, &idx.wide},
            {"octree", nullptr, &idx.octree, nullptr, nullptr, true},
            {"kd", nullptr, &idx.kd, nullptr, nullptr, false, true}};
}

void sylva_first_hits(const Variant& v, const std::vector<Sphere>& spheres, std::span<const sylva::Ray> rays,
                      sylva::ThreadPool& pool, FirstHits& out) {
    std::span<const std::uint32_t> w(*v.words);
    std::span<const Sphere> es(spheres);
    pool.parallel_for(0, rays.size(), 1024, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) {
            auto h = v.element_kd       ? sylva::kdtree::first_hit(w, es, rays[i])
                     : v.element_octree ? sylva::octree::first_hit(w, es, rays[i])
                     : v.wide         ? bih::first_hit(*v.wide, rays[i])
                     : v.records      ? bih::first_hit(w, *v.records, rays[i])
                                      : bih::first_hit(w, *v.tree, es, rays[i]);
            out.id[i] = h ? h->element : kNoHit;
        }
    });
}

void sylva_all_hits(const Variant& v, const std::vector<Sphere>& spheres, std::span<const sylva::Ray> rays,
                    sylva::ThreadPool& pool, AllHits& out) {
    std::span<const std::uint32_t> w(*v.words);
    std::span<const Sphere> es(spheres);
    pool.parallel_for(0, rays.size(), 1024, [&](std::size_t lo, std::size_t hi) {
        std::vector<bih::ElementHit> hits;
        for (std::size_t i = lo; i < hi; ++i) {
            if (v.element_kd)
                sylva::kdtree::all_hits(w, es, rays[i], hits);
            else if (v.element_octree)
                sylva::octree::all_hits(w, es, rays[i], hits);
            else if (v.wide)
                bih::all_hits(*v.wide, rays[i], hits);
            else if (v.records)
                bih::all_hits(w, *v.records, rays[i], hits);
            else
                bih::all_hits(w, *v.tree, es, rays[i], hits);
            std::uint64_t set = 0;
            for (const auto& h : hits) set += mix_id(h.element);
            out.count[i] = static_cast<std::uint32_t>(hits.size());
            out.set[i] = set;
        }
    });
}

HitList sylva_hit_list(const Variant& v, const std::vector<Sphere>& spheres) {
    return [v, &spheres](const sylva::Ray& ray) {
        std::vector<bih::ElementHit> hits;
        if (v.element_kd)
            sylva::kdtree::all_hits(std::span<const std::uint32_t>(*v.words), std::span<const Sphere>(spheres), ray, hits);
        else if (v.element_octree)
            sylva::octree::all_hits(std::span<const std::uint32_t>(*v.words), std::span<const Sphere>(spheres), ray, hits);
        else if (v.wide)
            bih::all_hits(*v.wide, ray, hits);
        else if (v.records)
            bih::all_hits(std::span<const std::uint32_t>(*v.words), *v.records, ray, hits);
        else
            bih::all_hits(std::span<const std::uint32_t>(*v.words), *v.tree, std::span<const Sphere>(spheres), ray, hits);
        std::vector<std::uint32_t> ids;
        for (const auto& h : hits) ids.push_back(h.element);
        return ids;
    };
}

TraversalCost sylva_cost(const Variant& v, const std::vector<Sphere>& spheres, std::span<const sylva::Ray> rays,
                         bool first) {
    rays = rays.first(std::min<std::size_t>(rays.size(), 10000));
    double steps = 0.0, leaves = 0.0;
    double n = static_cast<double>(std::max<std::size_t>(rays.size(), 1));
    if (v.wide) {  // wide nodes and leaves of the all-hits walk (first hit prunes some of them)
        for (const sylva::Ray& ray : rays) {
            auto visits = v.wide->visits(ray);
            steps += static_cast<double>(visits.nodes);
            leaves += static_cast<double>(visits.leaves);
        }
        return {steps / n, leaves / n};
    }
    if (v.element_octree) return octree_cost(*v.words, spheres, rays, first);
    if (v.element_kd) return kd_cost(*v.words, spheres, rays, first);
    for (const sylva::Ray& ray : rays) {
        bih::LeafIterator it(std::span<const std::uint32_t>(*v.words), ray);
        float best = std::numeric_limits<float>::infinity();
        while (auto leaf = it.next()) {
            leaves += 1.0;
            if (!first) continue;
            auto [lo, count] = bih::decode_range(leaf->payload);
            for (std::uint32_t k = 0; k < count; ++k) {
                auto t = sylva::intersect_element(spheres[v.tree->order[lo + k]], ray, sylva::Interval{});
                if (t && t->t0 < best) it.clip(best = t->t0);
            }
        }
        steps += it.steps();
    }
    return {steps / n, leaves / n};
}

double stream_gb_per_s(const std::vector<std::uint32_t>& words, sylva::ThreadPool& pool, std::size_t runs) {
    std::atomic<std::uint64_t> sink{0};
    double ms = median(samples(runs, 0.0, [&] {
        return time_ms([&] {
            pool.parallel_for(0, words.size(), 1u << 16, [&](std::size_t lo, std::size_t hi) {
                std::uint64_t s = 0;
                for (std::size_t i = lo; i < hi; ++i) s += words[i];
                sink.fetch_add(s, std::memory_order_relaxed);
            });
        });
    }));
    g_sink = sink.load();  // keeps the sums alive
    return static_cast<double>(words.size() * 4) / (std::max(ms, 1e-6) * 1e6);
}

}  // namespace bench
