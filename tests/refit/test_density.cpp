// Full BIH statistics and LoD over any DensityElement (issue 14, item 4): Gaussian RBFs that
// carry their density through ADL functions (no data members, not a VoxelCuboid); node
// statistics against brute force over the elements under each node, LoD leaves against the
// statistics of their source nodes.
#include <catch2/catch.hpp>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/elements/rbf.hpp>

#include "../kd_elements/common.hpp"

namespace rbf_density {

/// A Gaussian RBF whose peak density is its colour's alpha and whose gradient is a fixed tilt.
struct RbfSample {
    sylva::GaussianRbf rbf;
    [[nodiscard]] sylva::Aabb bounds() const { return sylva::bounds_of(rbf); }
};
inline float element_density(const RbfSample& s) { return s.rbf.rgba.a; }
inline sylva::vec3 element_gradient(const RbfSample& s) { return 0.01f * (s.rbf.rgba.r - 0.5f) * sylva::vec3(1.0f, -2.0f, 0.5f); }

}  // namespace rbf_density

using namespace sylva;
using rbf_density::RbfSample;

static_assert(bih::DensityElement<RbfSample>);
static_assert(bih::DensityElement<VoxelCuboid>);
static_assert(!bih::DensityElement<GaussianRbf>);

namespace {

/// The elements under node n (its subtree's leaves), by walking the tree.
std::vector<std::uint32_t> under(const bih::Tree& t, std::uint32_t n) {
    std::vector<std::uint32_t> out, stack{n};
    while (!stack.empty()) {
        const bih::Node& node = t.nodes[stack.back()];
        stack.pop_back();
        if (node.leaf()) {
            for (std::uint32_t k = 0; k < node.count; ++k) out.push_back(t.order[node.first + k]);
            continue;
        }
        for (int c = 0; c < 2; ++c)
            if (node.child[c] != bih::kNoChild && !(node.single && c == 1)) stack.push_back(node.child[c]);
    }
    return out;
}

}  // namespace

TEST_CASE("density: full BIH statistics and LoD over Gaussian RBFs equal brute force", "[density]") {
    std::vector<RbfSample> es;
    for (const GaussianRbf& g : kde_test::random_rbfs(3000, 301)) es.push_back({g});
    std::span<const RbfSample> s(es);
    ThreadPool pool(2);
    bih::FullBih f = bih::build_full(s, bih::Config{}, pool);
    REQUIRE(f.stats.size() == f.tree.nodes.size());
    std::size_t checked = 0;
    for (std::uint32_t n = 0; n < f.tree.nodes.size(); n += 7) {
        auto elems = under(f.tree, n);
        const bih::NodeStats& st = f.stats[n];
        REQUIRE(st.count == elems.size());
        double mean = 0.0, volume = 0.0;
        float dmin = INFINITY, dmax = -INFINITY;
        glm::dvec3 grad(0.0);
        for (std::uint32_t e : elems) {
            float d = rbf_density::element_density(es[e]);
            mean += d;
            grad += glm::dvec3(rbf_density::element_gradient(es[e]));
            dmin = std::min(dmin, d);
            dmax = std::max(dmax, d);
            vec3 x = bounds_of(es[e]).extent();
            volume += double(x.x) * x.y * x.z;
        }
        mean /= double(elems.size());
        grad /= double(elems.size());
        double m2 = 0.0;
        for (std::uint32_t e : elems) m2 += (rbf_density::element_density(es[e]) - mean) * (rbf_density::element_density(es[e]) - mean);
        CHECK(st.mean == Approx(mean).margin(1e-9));
        CHECK(st.variance() == Approx(m2 / double(elems.size())).margin(1e-9));
        CHECK(st.element_volume == Approx(volume).epsilon(1e-9));
        CHECK(st.min_density == dmin);
        CHECK(st.max_density == dmax);
        CHECK(st.mean_gradient.y == Approx(grad.y).margin(1e-6));
        ++checked;
    }
    CHECK(checked > 500);
    // LoD: loose criteria merge whole subtrees of overlapping RBFs; every LoD leaf carries its
    // source node's box, mean density and mean gradient, and the leaves hold every element once.
    bih::LodConfig lc;
    lc.min_element_density = 0.5f;
    lc.max_std_dev = 0.2f;
    bih::Lod lod = bih::extract_lod(f, lc);
    REQUIRE(lod.leaves.size() > 10);
    REQUIRE(lod.leaves.size() < es.size());
    std::size_t covered = 0;
    for (std::size_t n = 0; n < lod.tree.nodes.size(); ++n) {
        const bih::Node& node = lod.tree.nodes[n];
        if (!node.leaf()) continue;
        std::uint32_t src = lod.source[n];
        auto elems = under(f.tree, src);
        covered += elems.size();
        double mean = 0.0;
        for (std::uint32_t e : elems) mean += rbf_density::element_density(es[e]);
        mean /= double(elems.size());
        const VoxelCuboid& leaf = lod.leaves[node.first];
        CHECK(leaf.density == Approx(mean).margin(1e-6));
        CHECK(leaf.box == f.boxes[src]);
    }
    CHECK(covered == es.size());
    auto words = bih::encode_lod(lod, lc);
    CHECK(words.size() > 16);
}
