// The serial (Vidal), parallel (Zellmann Alg. 1) and binned (Zellmann section 4.3) builders:
// tree invariants against the occupancy, split choices against brute force, equal trees where
// the algorithms promise them, halting criteria, and the subvolume list under a budget.
#include <catch2/catch.hpp>

#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/build_parallel.hpp>
#include <sylva/kdtree/subvolumes.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;
using kdtree::Config;
using kdtree::Tree;

namespace {

std::vector<Occupancy> build_volumes() {
    std::vector<Occupancy> v;
    v.push_back(blobby_occupancy({64, 48, 40}, 1));
    v.push_back(blobby_occupancy({37, 70, 29}, 2, 8));
    v.push_back(random_occupancy({45, 33, 50}, 0.002, 3));
    v.push_back(random_occupancy({40, 40, 40}, 0.3, 4));
    v.push_back(random_occupancy({1, 1, 1}, 1.0, 5));
    v.push_back(random_occupancy({1, 1, 1}, 0.0, 6));
    v.push_back(random_occupancy({1, 90, 1}, 0.1, 7));
    v.push_back(random_occupancy({33, 1, 1}, 1.0, 8));
    v.push_back(random_occupancy({20, 30, 25}, 0.0, 9));
    v.push_back(random_occupancy({20, 30, 25}, 1.0, 10));
    return v;
}

std::vector<std::pair<const char*, Config>> configs() {
    Config small_step = Config::shallow();
    small_step.plane_step = 1;
    Config deep_step2 = Config::deep();
    deep_step2.plane_step = 2;
    return {{"shallow", Config::shallow()},          {"deep", Config::deep()},
            {"shallow binned", Config::shallow().binned()}, {"deep binned 8", Config::deep().binned(8)},
            {"shallow step 1", small_step},          {"deep step 2", deep_step2}};
}

std::string dims_text(const Occupancy& o) {
    return std::to_string(o.dims.x) + "x" + std::to_string(o.dims.y) + "x" + std::to_string(o.dims.z);
}

/// Brute-force version of the driver's decision for an inner node or a leaf: the best plane's
/// cost from scanned tight boxes, and whether any plane removes enough empty space.
struct BruteSplit {
    std::uint64_t best_cost = ~std::uint64_t{0};
    std::uint32_t best_plane = 0;
    bool any_plane = false;
};

BruteSplit brute_split(const Occupancy& o, const VoxelBox& box, const Config& c) {
    BruteSplit r;
    int axis = box.longest_axis();
    std::vector<std::uint32_t> planes;
    kdtree::detail::candidate_planes(box, axis, c, o.dims, planes);
    double middle = (double(box.lo[axis]) + double(box.hi[axis])) / 2.0;
    for (std::uint32_t p : planes) {
        VoxelBox lo = box, hi = box;
        lo.hi[axis] = p;
        hi.lo[axis] = p;
        std::uint64_t cost = tight_direct(o, lo).volume() + tight_direct(o, hi).volume();
        r.any_plane = true;
        bool nearer = std::abs(double(p) - middle) < std::abs(double(r.best_plane) - middle);
        if (cost < r.best_cost || (cost == r.best_cost && nearer)) r.best_cost = cost, r.best_plane = p;
    }
    return r;
}

/// Checks every node against the halting criteria and the brute-force best plane.
void check_decisions(const Tree& t, const Occupancy& o, const Config& c) {
    double voxels = static_cast<double>(o.voxels.size());
    double min_volume = std::max(c.min_volume_fraction * voxels, double(c.min_volume_voxels));
    for (const kdtree::Node& n : t.nodes) {
        double vol = double(n.box.volume());
        bool small = vol < min_volume || n.depth >= std::min(c.max_depth, SYLVA_KD_DEPTH_CAP);
        BruteSplit b = brute_split(o, n.box, c);
        if (n.is_leaf()) {
            bool removes_enough = b.any_plane && vol - double(b.best_cost) >= c.min_removed_fraction * vol;
            REQUIRE((small || !removes_enough));
            continue;
        }
        REQUIRE_FALSE(small);
        REQUIRE(n.box.longest_axis() == n.axis);
        REQUIRE(n.plane == b.best_plane);  // least cost (Vidal eq. 1), ties to the middle
        REQUIRE(vol - double(b.best_cost) >= c.min_removed_fraction * vol);
    }
}

}  // namespace

TEST_CASE("build: the serial builder culls only empty space and picks the cheapest plane", "[build]") {
    for (const Occupancy& o : build_volumes()) {
        for (auto [name, cfg] : configs()) {
            INFO(dims_text(o) << " with " << o.count() << " occupied, config " << name);
            Tree t = kdtree::build_vidal(o, cfg);
            check_tree(t, o);
            check_decisions(t, o, cfg);
        }
    }
}

TEST_CASE("build: the parallel partial-SVT builder gives the serial builder's tree", "[build][parallel]") {
    ThreadPool pool1(1), pool2(2);
    for (const Occupancy& o : build_volumes()) {
        for (auto [name, cfg] : configs()) {
            INFO(dims_text(o) << ", config " << name);
            Tree serial = kdtree::build_vidal(o, cfg);
            Tree p32 = kdtree::build_parallel<32>(o, cfg, pool2);
            Tree p8 = kdtree::build_parallel<8>(o, cfg, pool1);
            Tree p7 = kdtree::build_parallel<7>(o, cfg, pool2);
            REQUIRE(p32.nodes == serial.nodes);
            REQUIRE(p8.nodes == serial.nodes);
            REQUIRE(p7.nodes == serial.nodes);
            REQUIRE(p32.leaves == serial.leaves);
        }
    }
}

TEST_CASE("build: the binned builder gives the serial builder's tree on the same binned planes", "[build][binned]") {
    ThreadPool pool(2);
    SerialExecutor serial_exec;
    for (const Occupancy& o : build_volumes()) {
        for (std::uint32_t bins : {2u, 4u, 8u, 16u}) {
            for (Config base : {Config::shallow(), Config::deep()}) {
                Config cfg = base.binned(bins);
                INFO(dims_text(o) << ", " << bins << " bins, min volume " << cfg.min_volume_voxels);
                Tree serial = kdtree::build_vidal(o, cfg);
                Tree binned = kdtree::build_binned(o, cfg, pool);
                REQUIRE(binned.nodes == serial.nodes);
                REQUIRE(kdtree::build_binned(o, cfg, serial_exec).nodes == serial.nodes);
                check_tree(binned, o);
            }
        }
    }
}

TEST_CASE("build: binned planes lie on the raster, inside the box, ascending", "[build][binned]") {
    Config c = Config::shallow().binned(4);
    std::vector<std::uint32_t> p;
    kdtree::detail::candidate_planes(VoxelBox{uvec3(3, 0, 0), uvec3(13, 1, 1)}, 0, c, {64, 64, 64}, p);
    CHECK(p == std::vector<std::uint32_t>{8});
    kdtree::detail::candidate_planes(VoxelBox{uvec3(0, 0, 0), uvec3(256, 1, 1)}, 0, c, {256, 256, 256}, p);
    CHECK(p == std::vector<std::uint32_t>{64, 128, 192});
    kdtree::detail::candidate_planes(VoxelBox{uvec3(1, 0, 0), uvec3(8, 1, 1)}, 0, c, {64, 64, 64}, p);
    CHECK(p.empty());  // no raster line strictly inside
    kdtree::detail::candidate_planes(VoxelBox{uvec3(7, 0, 0), uvec3(9, 1, 1)}, 0, c, {64, 64, 64}, p);
    CHECK(p == std::vector<std::uint32_t>{8});  // rounding misses it, the fallback finds it
    Config s = Config::shallow();
    kdtree::detail::candidate_planes(VoxelBox{uvec3(0, 0, 0), uvec3(256, 1, 1)}, 0, s, {256, 256, 256}, p);
    CHECK(p.size() == 63);  // Vidal: Δl = 4 on 256^3, fewer than 64 planes
    CHECK((p.front() == 4 && p.back() == 252));
    kdtree::detail::candidate_planes(VoxelBox{uvec3(0, 0, 0), uvec3(512, 1, 1)}, 0, s, {512, 512, 512}, p);
    CHECK((p.size() == 63 && p.front() == 8));  // Δl = 8 on 512^3
    kdtree::detail::candidate_planes(VoxelBox{uvec3(10, 0, 0), uvec3(13, 1, 1)}, 0, s, {256, 256, 256}, p);
    CHECK(p == std::vector<std::uint32_t>{11, 12});  // shorter than Δl: every voxel plane
}

TEST_CASE("build: the binned tree culls nearly as much empty space as the serial tree", "[build][binned]") {
    // Stated amount: on these sparse volumes 4 bins on the 8-voxel raster keep within 15
    // percentage points of Vidal's every-Δl planes (Zellmann Table 1 reports 2-6 points on real data).
    ThreadPool pool(2);
    for (std::uint32_t seed : {11u, 12u, 13u, 14u}) {
        Occupancy o = blobby_occupancy({96, 80, 64}, seed, 6);
        for (Config cfg : {Config::shallow(), Config::deep()}) {
            Tree serial = kdtree::build_vidal(o, cfg);
            Tree binned = kdtree::build_binned(o, cfg, pool);
            INFO("seed " << seed << ": serial " << serial.stats.percent_culled() << " %, binned "
                         << binned.stats.percent_culled() << " %");
            CHECK(binned.stats.percent_culled() >= serial.stats.percent_culled() - 15.0);
            CHECK(binned.stats.percent_culled() > 0.0);
        }
    }
}

TEST_CASE("build: deep trees cull more empty space than shallow ones", "[build]") {
    for (std::uint32_t seed : {21u, 22u, 23u}) {
        Occupancy o = blobby_occupancy({80, 64, 72}, seed, 6);
        Tree shallow = kdtree::build_vidal(o, Config::shallow());
        Tree deep = kdtree::build_vidal(o, Config::deep());
        INFO("shallow " << shallow.stats.percent_culled() << " %, deep " << deep.stats.percent_culled() << " %");
        CHECK(deep.stats.percent_culled() > shallow.stats.percent_culled());
        CHECK(deep.leaves.size() > shallow.leaves.size());
        CHECK(shallow.stats.max_depth <= 10u);
    }
}

TEST_CASE("build: degenerate grids", "[build]") {
    SerialExecutor serial;
    SECTION("all empty: no nodes, nothing occupied") {
        Occupancy o = random_occupancy({31, 17, 9}, 0.0, 1);
        for (Tree t : {kdtree::build_vidal(o), kdtree::build_parallel(o, Config{}, serial), kdtree::build_binned(o, Config{}, serial)}) {
            CHECK(t.nodes.empty());
            CHECK(t.leaves.empty());
            CHECK(t.stats.percent_culled() == 100.0);
        }
    }
    SECTION("all full: shallow is the root alone; deep splits yet keeps every voxel") {
        Occupancy o = random_occupancy({24, 20, 16}, 1.0, 1);
        Tree s = kdtree::build_vidal(o);
        CHECK(s.nodes.size() == 1);
        CHECK(s.nodes[0].box == volume::full_box(o.dims));
        CHECK(s.stats.percent_culled() == 0.0);
        Tree d = kdtree::build_vidal(o, Config::deep());
        check_tree(d, o);
        for (std::uint32_t n : d.leaves) CHECK(d.nodes[n].box.volume() < 512u);
    }
    SECTION("one voxel") {
        Occupancy o = random_occupancy({1, 1, 1}, 1.0, 1);
        Tree t = kdtree::build_parallel(o, Config::deep(), serial);
        REQUIRE(t.nodes.size() == 1);
        CHECK(t.nodes[0].box == volume::full_box(o.dims));
    }
    SECTION("a single occupied voxel in a large grid is one tight leaf") {
        Occupancy o = random_occupancy({50, 60, 70}, 0.0, 1);
        o.voxels[volume::voxel_index(o.dims, 49, 0, 33)] = 1;
        Tree t = kdtree::build_binned(o, Config::deep(), serial);
        REQUIRE(t.nodes.size() == 1);
        CHECK(t.nodes[0].box == VoxelBox{uvec3(49, 0, 33), uvec3(50, 1, 34)});
    }
}

TEST_CASE("build: bad configurations are errors", "[build]") {
    Occupancy o = random_occupancy({8, 8, 8}, 0.5, 1);
    SerialExecutor serial;
    Config c;
    c.min_volume_fraction = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(kdtree::build_vidal(o, c), Error);
    c = Config{};
    c.min_removed_fraction = 1.5;
    CHECK_THROWS_AS(kdtree::build_vidal(o, c), Error);
    c = Config::shallow().binned(1);
    CHECK_THROWS_AS(kdtree::build_vidal(o, c), Error);
    c = Config::shallow().binned(4);
    c.raster = 12;  // cuts 8^3 blocks
    CHECK_THROWS_AS(kdtree::build_binned(o, c, serial), Error);
}

TEST_CASE("build: the depth cap holds even with no other limit", "[build]") {
    Config c = Config::deep();
    c.min_volume_voxels = 0;
    c.max_depth = 3;
    Occupancy o = random_occupancy({30, 30, 30}, 0.2, 3);
    Tree t = kdtree::build_vidal(o, c);
    CHECK(t.stats.max_depth == 3u);
    check_tree(t, o);
}

TEST_CASE("subvolumes: at most M disjoint boxes holding every occupied voxel", "[subvolumes]") {
    Occupancy o = blobby_occupancy({64, 64, 48}, 31, 8);
    Tree t = kdtree::build_vidal(o, Config::deep());
    REQUIRE(t.leaves.size() > 20);
    CHECK(kdtree::subvolumes(t, 1) == std::vector<VoxelBox>{t.nodes[0].box});
    CHECK(kdtree::subvolumes(t, static_cast<std::uint32_t>(t.leaves.size())).size() == t.leaves.size());
    CHECK(kdtree::subvolumes(t, 100000).size() == t.leaves.size());
    std::uint64_t occupied = o.count();
    for (std::uint32_t m : {2u, 3u, 5u, 8u, 13u, 16u}) {
        std::vector<VoxelBox> boxes = kdtree::subvolumes(t, m);
        INFO("budget " << m << ": " << boxes.size() << " boxes");
        CHECK(boxes.size() <= m);
        CHECK(boxes.size() >= std::min<std::size_t>(m - 1, t.leaves.size()) / 2);
        std::vector<std::uint8_t> cover(o.voxels.size(), 0);
        std::uint64_t held = 0;
        for (const VoxelBox& b : boxes) {
            held += count_direct(o, b);
            for (std::uint32_t z = b.lo.z; z < b.hi.z; ++z)
                for (std::uint32_t y = b.lo.y; y < b.hi.y; ++y)
                    for (std::uint32_t x = b.lo.x; x < b.hi.x; ++x) REQUIRE(cover[volume::voxel_index(o.dims, x, y, z)]++ == 0);
        }
        CHECK(held == occupied);
    }
    CHECK_THROWS_AS(kdtree::subvolume_nodes(t, 0), Error);
}

TEST_CASE("subvolumes: the budget is shared in proportion to the leaves below", "[subvolumes]") {
    // A hand-made tree: root -> (A: 3 leaves, B: 1 leaf). Budget 2: A gets ceil(2 * 3 / 4) = 2,
    // capped at 1, B the rest. Budget 3: A gets ceil(9 / 4) = 3, capped at 2, which A splits
    // into its lower child (2 leaves, budget 1) and its leaf.
    Tree t;
    t.dims = {16, 4, 4};
    auto box = [](std::uint32_t lo, std::uint32_t hi) { return VoxelBox{uvec3(lo, 0, 0), uvec3(hi, 4, 4)}; };
    t.nodes.resize(7);
    t.nodes[0] = {box(0, 16), 1, kdtree::kNone, 12, 0, 0};
    t.nodes[1] = {box(0, 12), 3, kdtree::kNone, 6, 0, 1};  // A
    t.nodes[2] = {box(12, 16), kdtree::kNone, kdtree::kNone, 0, kdtree::kLeaf, 1};  // B
    t.nodes[3] = {box(0, 6), 5, kdtree::kNone, 3, 0, 2};
    t.nodes[4] = {box(6, 12), kdtree::kNone, kdtree::kNone, 0, kdtree::kLeaf, 2};
    t.nodes[5] = {box(0, 3), kdtree::kNone, kdtree::kNone, 0, kdtree::kLeaf, 3};
    t.nodes[6] = {box(3, 6), kdtree::kNone, kdtree::kNone, 0, kdtree::kLeaf, 3};
    CHECK(kdtree::subvolume_nodes(t, 1) == std::vector<std::uint32_t>{0});
    CHECK(kdtree::subvolume_nodes(t, 2) == std::vector<std::uint32_t>{1, 2});
    CHECK(kdtree::subvolume_nodes(t, 3) == std::vector<std::uint32_t>{3, 4, 2});  // A gets ceil(9/4) = 3 -> 2
    CHECK(kdtree::subvolume_nodes(t, 4) == std::vector<std::uint32_t>{5, 6, 4, 2});
}

namespace {
struct NotASplitter {
    VoxelBox root_box() const { return {}; }
};
static_assert(kdtree::Splitter<kdtree::SvtSplitter<std::uint32_t>>);
static_assert(kdtree::Splitter<kdtree::PartialSvtSplitter<32, ThreadPool>>);
static_assert(kdtree::Splitter<kdtree::BinnedSplitter<SerialExecutor>>);
static_assert(!kdtree::Splitter<NotASplitter>);
static_assert(!kdtree::Splitter<int>);
}  // namespace
