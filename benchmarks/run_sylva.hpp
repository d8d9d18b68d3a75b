// benchmarks/run_sylva.hpp -- sylva's side of each case: BIH build, encode, first hit, all hits.
#ifndef SYLVA_BENCH_RUN_SYLVA_HPP
#define SYLVA_BENCH_RUN_SYLVA_HPP

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <sylva/bih/query.hpp>
#include <sylva/bih/tree.hpp>
#include <sylva/bih/wide.hpp>
#include <sylva/bih/wide_build.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/octree/elements.hpp>

#include "bench.hpp"

namespace bench {

/// A built tree and its two RangePayload encodings (the queries' inputs), plus a second tree
/// with up to 4 spheres per untrimmed leaf (what the default's one trimmed sphere per leaf costs),
/// and the query tree (bih::Config::for_queries()) with its spheres in leaf order.
struct SylvaIndex {
    sylva::bih::Tree tree;
    std::vector<std::uint32_t> fixed16;
    std::vector<std::uint32_t> float32;
    sylva::bih::Tree leaf4_tree;
    std::vector<std::uint32_t> leaf4;  ///< fixed16 encoding of leaf4_tree
    sylva::bih::Tree query_tree;
    std::vector<std::uint32_t> query;  ///< fixed16 encoding of query_tree
    sylva::bih::LeafRecords<sylva::Sphere> query_records;
    sylva::bih::Tree wide_tree;                ///< the BIH of bih::wide_source_config (TreeKind::Wide)
    sylva::bih::WideTree<sylva::Sphere> wide;  ///< wide_tree collapsed (bih::WideTree, WideConfig{})
    std::vector<double> wide_ms;               ///< the collapse's timed runs
    sylva::octree::ElementTree octree_tree;    ///< the element octree (octree::ElementConfig{}), spheres in order
    std::vector<std::uint32_t> octree;         ///< its encoding (octree::encode_elements)
    sylva::kdtree::ElementTree kd_tree;        ///< the element kd-tree (kdtree::ElementConfig{}), spheres in order
    std::vector<std::uint32_t> kd;             ///< its encoding (kdtree::encode_elements)
};

/// One encoding the traversal cases run: its name in case names, its tree and words, and the
/// spheres in leaf order where the variant uses them (else the queries go through tree.order).
struct Variant {
    std::string name;
    const sylva::bih::Tree* tree;
    const std::vector<std::uint32_t>* words;
    const sylva::bih::LeafRecords<sylva::Sphere>* records = nullptr;
    const sylva::bih::WideTree<sylva::Sphere>* wide = nullptr;  ///< queries run on this when set
    bool element_octree = false;  ///< `words` is an element octree (octree::first_hit / all_hits)
    bool element_kd = false;      ///< `words` is an element kd-tree (kdtree::first_hit / all_hits)
};
/// fixed16 and float32 of the default tree, fixed16-leaf4, fixed16-query, wide, then the
/// element octree ("octree").
std::vector<Variant> variants(const SylvaIndex& idx);

/// What each configuration name in case names means (build and encode settings, query path).
void describe_configs(Report& report);

/// The builds the cases time: Default bih::Config{} (one trimmed sphere per leaf), Leaf4 (4
/// spheres a leaf, untrimmed), Query (bih::Config::for_queries()) and Wide
/// (bih::wide_source_config: the BIH a WideTree is collapsed from, leaves of its leaf size).
enum class TreeKind { Default, Leaf4, Query, Wide };
/// One timed bih::build into `out` (its previous tree is freed before the clock starts); ms.
double time_sylva_build(sylva::bih::Tree& out, const std::vector<sylva::Sphere>& spheres, TreeKind kind,
                        sylva::ThreadPool& pool);
/// One timed octree::build_elements (ElementConfig{}) into `out`; ms.
double time_octree_build(sylva::octree::ElementTree& out, const std::vector<sylva::Sphere>& spheres,
                         sylva::ThreadPool& pool);
/// One timed kdtree::build_elements (ElementConfig{}) into `out`; ms.
double time_kd_build(sylva::kdtree::ElementTree& out, const std::vector<sylva::Sphere>& spheres, sylva::ThreadPool& pool);
/// Records the element kd-tree's median build time, elements/s, runs and shape under `name`.
void record_kd_build(Report& report, const std::string& name, const std::string& peer, const std::vector<double>& ms,
                     const sylva::kdtree::ElementTree& tree);
/// Records the element octree's median build time, elements/s, runs and shape (nodes, levels,
/// references per sphere) under `name`.
void record_octree_build(Report& report, const std::string& name, const std::string& peer,
                         const std::vector<double>& ms, const sylva::octree::ElementTree& tree);
/// Records a build's median time, elements/s, runs and the tree's shape under `name`.
void record_sylva_build(Report& report, const std::string& name, const std::string& peer,
                        const std::vector<double>& ms, const sylva::bih::Tree& tree, const std::string& config);

/// Times the encoders (on `pool`) over idx.tree (fixed16 and float32 with RangePayload, fixed16
/// with ParticlePayload) and the query tree (fixed16, and its LeafRecords) under
/// "encode/<label>/..."; fills idx's encodings (leaf4 untimed).
void bench_sylva_encode(SylvaIndex& idx, const std::vector<sylva::Sphere>& spheres, const Options& opt,
                        Report& report, const std::string& label, sylva::ThreadPool& pool);

/// One pass of bih::first_hit over all rays, in parallel on `pool`, into `out` (prepare()d for
/// rays.size(); every entry written).
void sylva_first_hits(const Variant& v, const std::vector<sylva::Sphere>& spheres, std::span<const sylva::Ray> rays,
                      sylva::ThreadPool& pool, FirstHits& out);

/// One pass of bih::all_hits over all rays, in parallel on `pool`, into `out` (as above).
void sylva_all_hits(const Variant& v, const std::vector<sylva::Sphere>& spheres, std::span<const sylva::Ray> rays,
                    sylva::ThreadPool& pool, AllHits& out);

/// bih::all_hits of one ray as a list of element ids (for re-examining disagreements).
HitList sylva_hit_list(const Variant& v, const std::vector<sylva::Sphere>& spheres);

/// Mean inner and leaf nodes the iterator visits per ray (first hit: with the clipping that
/// bih::first_hit does), measured on up to 10000 of `rays` outside any timing.
struct TraversalCost {
    double nodes_per_ray = 0.0;
    double leaves_per_ray = 0.0;
};
TraversalCost sylva_cost(const Variant& v, const std::vector<sylva::Sphere>& spheres,
                         std::span<const sylva::Ray> rays, bool first);

/// GB/s of a parallel streaming pass that sums `words` (median of `runs`): the rate at which
/// this machine can read the encoding at all.
double stream_gb_per_s(const std::vector<std::uint32_t>& words, sylva::ThreadPool& pool, std::size_t runs);

}  // namespace bench

#endif  // SYLVA_BENCH_RUN_SYLVA_HPP
