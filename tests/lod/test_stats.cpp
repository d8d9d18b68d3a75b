// Node statistics (Kinkelin 5.2) against brute force over the elements under each node.
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>

#include <sylva/bih/stats.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/elements/box.hpp>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;

namespace {

/// A user element: a point-like sample with a density, not a VoxelCuboid.
struct Sample {
    Aabb box;
    float density = 0.0f;
    vec3 gradient{0.0f};
    [[nodiscard]] Aabb bounds() const { return box; }
};

static_assert(bih::DensityElement<VoxelCuboid>);
static_assert(bih::DensityElement<Sample>);
static_assert(!bih::DensityElement<BoxElement>);
static_assert(!bih::DensityElement<int>);

/// Brute-force reference of what node_stats must report for `elems` under a node of box `box`.
struct Reference {
    std::size_t count = 0;
    double volume = 0.0, mean = 0.0, variance = 0.0, density = 0.0;
    glm::dvec3 gradient{0.0};
    float dmin = 1e30f, dmax = -1e30f, rmin = 1e30f, rmax = -1e30f;
};

template <class E>
Reference reference(std::span<const E> all, const std::vector<std::uint32_t>& elems, const Aabb& box, vec3 voxel) {
    Reference r;
    r.count = elems.size();
    for (std::uint32_t i : elems) {
        const E& e = all[i];
        vec3 ext = e.box.extent();
        r.volume += double(ext.x) * ext.y * ext.z;
        r.mean += e.density;
        r.gradient += glm::dvec3(e.gradient);
        r.dmin = std::min(r.dmin, e.density);
        r.dmax = std::max(r.dmax, e.density);
        // extremes of the linear reconstruction sit at the box corners: evaluate all 8
        for (int c = 0; c < 8; ++c) {
            vec3 corner((c & 1) ? e.box.hi.x : e.box.lo.x, (c & 2) ? e.box.hi.y : e.box.lo.y,
                        (c & 4) ? e.box.hi.z : e.box.lo.z);
            float d = e.density + glm::dot(e.gradient, (corner - e.box.center()) / voxel);
            r.rmin = std::min(r.rmin, d);
            r.rmax = std::max(r.rmax, d);
        }
    }
    r.mean /= double(r.count);
    r.gradient /= double(r.count);
    for (std::uint32_t i : elems) r.variance += (all[i].density - r.mean) * (all[i].density - r.mean);
    r.variance /= double(r.count);
    vec3 be = box.extent();
    r.density = r.volume / (double(be.x) * be.y * be.z);
    return r;
}

void check_node(const bih::NodeStats& s, const Reference& r) {
    REQUIRE(s.count == r.count);
    CHECK(s.element_volume == Approx(r.volume).epsilon(1e-9));
    CHECK(s.element_density == Approx(r.density).epsilon(1e-6));
    CHECK(s.mean == Approx(r.mean).margin(1e-12));
    CHECK(s.variance() == Approx(r.variance).margin(1e-12));
    CHECK(s.mean_gradient.x == Approx(r.gradient.x).margin(1e-6));
    CHECK(s.mean_gradient.y == Approx(r.gradient.y).margin(1e-6));
    CHECK(s.mean_gradient.z == Approx(r.gradient.z).margin(1e-6));
    CHECK(s.min_density == r.dmin);
    CHECK(s.max_density == r.dmax);
    CHECK(s.min_reconstructed == Approx(r.rmin).margin(1e-5));
    CHECK(s.max_reconstructed == Approx(r.rmax).margin(1e-5));
}

}  // namespace

TEST_CASE("node statistics equal brute force over the elements under each node", "[stats]") {
    vec3 spacing(1.0f, 1.0f, 1.4f);
    volume::DensityGrid g = lodtest::synthetic_grid({30, 26, 20}, spacing, 7u);
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, 0.1f);
    REQUIRE(cuboids.size() > 2000);
    auto variant = GENERATE(bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite);
    bih::Config cfg;
    cfg.empty_children = variant;
    ThreadPool pool(2);
    bih::FullBih f = bih::build_full(cuboids, cfg, pool);
    REQUIRE(f.stats.size() == f.tree.nodes.size());
    REQUIRE(f.boxes.size() == f.tree.nodes.size());
    CHECK(f.voxel_size.x == Approx(1.0f));
    CHECK(f.voxel_size.z == Approx(1.4f));

    std::mt19937 rng(11);
    std::vector<std::uint32_t> picks{0u};
    for (int k = 0; k < 300; ++k) picks.push_back(std::uniform_int_distribution<std::uint32_t>(0, f.tree.nodes.size() - 1)(rng));
    std::span<const VoxelCuboid> all(cuboids);
    for (std::uint32_t n : picks) {
        INFO("node " << n);
        check_node(f.stats[n], reference(all, lodtest::subtree_elements(f.tree, n), f.boxes[n], spacing));
    }
    CHECK(f.stats[0].count == cuboids.size());
}

TEST_CASE("node boxes contain their elements and their children, leaves equal their element", "[stats]") {
    volume::DensityGrid g = lodtest::synthetic_grid({24, 20, 16}, vec3(1.0f, 2.0f, 1.4f), 9u);
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, 0.1f);
    auto variant = GENERATE(bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite);
    bih::Config cfg;
    cfg.empty_children = variant;
    bih::FullBih f = bih::build_full(cuboids, cfg);
    CHECK(f.boxes[0] == f.tree.bounds);
    for (std::size_t i = 0; i < f.tree.nodes.size(); ++i) {
        const bih::Node& n = f.tree.nodes[i];
        INFO("node " << i);
        for (std::uint32_t e : lodtest::subtree_elements(f.tree, static_cast<std::uint32_t>(i)))
            REQUIRE(f.boxes[i].contains(cuboids[e].box));
        if (n.leaf()) {
            REQUIRE(n.count == 1);
            CHECK(f.boxes[i] == cuboids[f.tree.order[n.first]].box);  // trimmed: the box is the element
            continue;
        }
        for (int c = 0; c < (n.single ? 1 : 2); ++c)
            if (n.child[c] != bih::kNoChild) REQUIRE(f.boxes[i].contains(f.boxes[n.child[c]]));
    }
}

TEST_CASE("statistics are deterministic: serial and thread-pool builds agree", "[stats][parallel]") {
    volume::DensityGrid g = lodtest::synthetic_grid({40, 30, 24}, vec3(1.0f), 13u);
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, 0.1f);
    bih::Config cfg;
    cfg.parallel_threshold = 256;  // force parallel subtrees
    ThreadPool pool(3);
    bih::FullBih a = bih::build_full(cuboids, cfg), b = bih::build_full(cuboids, cfg, pool);
    REQUIRE(a.tree.nodes.size() == b.tree.nodes.size());
    CHECK(a.stats[0].mean == b.stats[0].mean);
    CHECK(a.stats[0].m2 == Approx(b.stats[0].m2).epsilon(1e-12));
    CHECK(a.stats[0].min_reconstructed == b.stats[0].min_reconstructed);
    CHECK(a.tree.stats.max_depth == b.tree.stats.max_depth);
}

TEST_CASE("node_stats is generic over user elements with density and gradient", "[stats]") {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 10.0f), d(0.0f, 1.0f), gr(-0.2f, 0.2f);
    std::vector<Sample> samples(500);
    for (Sample& s : samples) {
        vec3 p(u(rng), u(rng), u(rng));
        s.box = Aabb{p, p + vec3(0.5f, 0.25f, 1.0f)};
        s.density = d(rng);
        s.gradient = vec3(gr(rng), gr(rng), gr(rng));
    }
    std::span<const Sample> all(samples);
    bih::Tree t = bih::build(all);
    std::vector<Aabb> boxes = bih::node_boxes(t);
    SerialExecutor serial;
    vec3 voxel = bih::smallest_extent(all);
    CHECK(voxel.x == Approx(0.5f).margin(1e-5));  // box corners p + extent round in float
    CHECK(voxel.y == Approx(0.25f).margin(1e-5));
    CHECK(voxel.z == Approx(1.0f).margin(1e-5));
    std::vector<bih::NodeStats> stats = bih::node_stats(t, all, std::span<const Aabb>(boxes), voxel, serial);
    for (std::uint32_t n : {0u, 1u, 2u, static_cast<std::uint32_t>(t.nodes.size() / 2)}) {
        INFO("node " << n);
        check_node(stats[n], reference(all, lodtest::subtree_elements(t, n), boxes[n], voxel));
    }
    // these elements overlap, so element densities may exceed 1 (checked against the
    // brute-force ratio above); the mean is the plain per-element mean
    double mean = 0.0;
    for (const Sample& s : samples) mean += s.density;
    CHECK(stats[0].mean == Approx(mean / samples.size()).margin(1e-12));
}

TEST_CASE("the pairwise merge equals a one-pass computation", "[stats]") {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> d(0.0f, 1.0f);
    bih::NodeStats all;
    std::vector<double> values;
    for (int i = 0; i < 1000; ++i) {
        VoxelCuboid c{Aabb{vec3(0.0f), vec3(1.0f)}, d(rng), vec3(0.0f)};
        values.push_back(c.density);
        all = bih::merge(all, bih::element_stats(c, i, vec3(1.0f)));
    }
    double mean = 0.0, var = 0.0;
    for (double v : values) mean += v;
    mean /= values.size();
    for (double v : values) var += (v - mean) * (v - mean);
    var /= values.size();
    CHECK(all.count == 1000);
    CHECK(all.mean == Approx(mean).margin(1e-12));
    CHECK(all.variance() == Approx(var).margin(1e-12));
    CHECK(all.std_dev() == Approx(std::sqrt(var)).margin(1e-12));
}
