// Occupancy, full and partial summed-volume tables: counts and tight boxes against direct
// counting and scanning, on random volumes and degenerate grids.
#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/local_boxes.hpp>
#include <sylva/volume/occupancy.hpp>
#include <sylva/volume/partial_svt.hpp>
#include <sylva/volume/svt.hpp>
#include <sylva/volume/classify.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;
using volume::PartialSvt;
using volume::SummedVolumeTable;

namespace {

/// Grids that stress block edges and degenerate shapes.
std::vector<Dims> test_dims() {
    return {{1, 1, 1}, {1, 37, 1}, {1, 1, 70}, {33, 1, 1}, {31, 33, 2}, {32, 32, 32}, {45, 17, 38}, {8, 9, 65}};
}

/// Compares every query of three tables with direct counting on random boxes.
template <class F>
void check_counts(const Occupancy& o, F&& count, std::uint32_t seed, int boxes = 300) {
    std::mt19937 rng(seed);
    REQUIRE(count(volume::full_box(o.dims)) == o.count());
    for (int i = 0; i < boxes; ++i) {
        VoxelBox b = random_box(o.dims, rng);
        REQUIRE(count(b) == count_direct(o, b));
    }
}

template <class F>
void check_tight(const Occupancy& o, F&& tight, std::uint32_t seed, int boxes = 120) {
    std::mt19937 rng(seed);
    REQUIRE(tight(volume::full_box(o.dims)) == tight_direct(o, volume::full_box(o.dims)));
    for (int i = 0; i < boxes; ++i) {
        VoxelBox b = random_box(o.dims, rng);
        REQUIRE(tight(b) == tight_direct(o, b));
    }
}

std::vector<Occupancy> test_volumes() {
    std::vector<Occupancy> v;
    std::uint32_t seed = 1;
    for (Dims d : test_dims()) {
        v.push_back(random_occupancy(d, 0.02, seed++));  // sparse
        v.push_back(random_occupancy(d, 0.5, seed++));   // half full
        v.push_back(random_occupancy(d, 0.0, seed++));   // all empty
        v.push_back(random_occupancy(d, 1.0, seed++));   // all full
        v.push_back(blobby_occupancy(d, seed++));
    }
    return v;
}

/// Classifying the volume (lookup tables for integers) and its density grid agree with a
/// direct count of the classifier over the normalised densities.
template <class C>
void check_classifier(const volume::Volume& v, const volume::DensityGrid& g, const C& c, SerialExecutor& serial) {
    Occupancy a = volume::classify(volume::classified(v, c), serial);
    Occupancy b = volume::classify(volume::classified(g, c), serial);
    REQUIRE(a.voxels == b.voxels);
    std::uint64_t direct = 0;
    for (float x : g.values) direct += c(x) ? 1u : 0u;
    CHECK(a.count() == direct);
    CHECK(volume::count_occupied(volume::classified(v, c), serial) == direct);
    CHECK(direct > 0);
    CHECK(direct < g.values.size());
}

}  // namespace

TEST_CASE("svt: counts and tight boxes match direct counting and scanning", "[svt]") {
    for (const Occupancy& o : test_volumes()) {
        INFO("dims " << o.dims.x << "x" << o.dims.y << "x" << o.dims.z << ", " << o.count() << " occupied");
        SummedVolumeTable<std::uint32_t> s32(o);
        SummedVolumeTable<std::uint64_t> s64(o);
        check_counts(o, [&](const VoxelBox& b) { return s32.count(b); }, 11);
        check_counts(o, [&](const VoxelBox& b) { return s64.count(b); }, 12);
        check_tight(o, [&](const VoxelBox& b) { return s32.tight_box(b); }, 13);
        REQUIRE(s32.total() == o.count());
    }
}

TEST_CASE("svt: boxes outside or across the grid are clipped; empty boxes count nothing", "[svt]") {
    Occupancy o = random_occupancy({9, 10, 11}, 1.0, 3);
    SummedVolumeTable<std::uint32_t> s(o);
    CHECK(s.count(VoxelBox{uvec3(5, 5, 5), uvec3(100, 100, 100)}) == 4u * 5u * 6u);
    CHECK(s.count(VoxelBox{uvec3(20, 0, 0), uvec3(30, 5, 5)}) == 0u);
    CHECK(s.count(VoxelBox{uvec3(3, 3, 3), uvec3(3, 9, 9)}) == 0u);
    CHECK(s.tight_box(VoxelBox{uvec3(3, 3, 3), uvec3(2, 9, 9)}).empty());
}

TEST_CASE("svt: the table width follows the voxel count and a narrow table refuses", "[svt]") {
    CHECK_FALSE(volume::svt_needs_64bit({1625, 1625, 1625}));  // 4,291,015,625 < 2^32
    CHECK(volume::svt_needs_64bit({1626, 1626, 1626}));        // 4,298,942,376 > 2^32
    CHECK(volume::svt_needs_64bit({2048, 2048, 1024}));
    CHECK_FALSE(volume::svt_needs_64bit({65535, 65537, 1}));   // 2^32 - 1 exactly fits
    Occupancy small = random_occupancy({7, 8, 9}, 0.3, 5);
    volume::AnySvt any = volume::make_svt(small);
    CHECK(any.index() == 0);
    // 16-bit entries hold 65535 voxels at most: 41^3 = 68921 must be refused, 40^3 accepted.
    CHECK_THROWS_AS(SummedVolumeTable<std::uint16_t>(random_occupancy({41, 41, 41}, 1.0, 1)), Error);
    Occupancy full40 = random_occupancy({40, 40, 40}, 1.0, 1);
    SummedVolumeTable<std::uint16_t> s16(full40);
    CHECK(s16.total() == 64000u);  // counts exact although intermediate sums wrap
    check_counts(full40, [&](const VoxelBox& b) { return s16.count(b); }, 7, 50);
}

TEST_CASE("partial svt: counts and tight boxes per block and across blocks", "[svt][partial]") {
    ThreadPool pool(2);
    SerialExecutor serial;
    for (const Occupancy& o : test_volumes()) {
        INFO("dims " << o.dims.x << "x" << o.dims.y << "x" << o.dims.z << ", " << o.count() << " occupied");
        PartialSvt<32> p32(o, pool);
        PartialSvt<8> p8(o, serial);
        PartialSvt<5> p5(o, pool);  // a block size that divides nothing
        REQUIRE(p32.total() == o.count());
        check_counts(o, [&](const VoxelBox& b) { return p32.count(b); }, 21);
        check_counts(o, [&](const VoxelBox& b) { return p8.count(b); }, 22);
        check_counts(o, [&](const VoxelBox& b) { return p5.count(b); }, 23);
        check_tight(o, [&](const VoxelBox& b) { return p32.tight_box(b); }, 24);
        check_tight(o, [&](const VoxelBox& b) { return p5.tight_box(b, pool); }, 25);
        for (std::size_t b = 0; b < p32.block_count(); ++b)
            REQUIRE(p32.block_total(b) == count_direct(o, p32.block_box(b)));
    }
}

TEST_CASE("partial svt: a rebuild reuses the storage and forgets the old occupancy", "[svt][partial]") {
    ThreadPool pool(2);
    Occupancy a = random_occupancy({40, 35, 33}, 0.4, 9), b = random_occupancy({40, 35, 33}, 0.01, 10);
    PartialSvt<32> p(a, pool);
    p.assign(b, pool);
    check_counts(b, [&](const VoxelBox& box) { return p.count(box); }, 31);
    check_tight(b, [&](const VoxelBox& box) { return p.tight_box(box); }, 32);
}

TEST_CASE("local boxes: every non-empty 8^3 block's tight box, Morton-sorted", "[svt][local]") {
    ThreadPool pool(2);
    for (const Occupancy& o : test_volumes()) {
        INFO("dims " << o.dims.x << "x" << o.dims.y << "x" << o.dims.z);
        kdtree::LocalBoxes lb = kdtree::local_boxes(o, pool);
        CHECK(lb.occupied == o.count());
        std::size_t nonempty = 0;
        for (std::uint32_t z = 0; z < lb.blocks.z; ++z)
            for (std::uint32_t y = 0; y < lb.blocks.y; ++y)
                for (std::uint32_t x = 0; x < lb.blocks.x; ++x) {
                    uvec3 lo = uvec3(x, y, z) * 8u;
                    VoxelBox t = tight_direct(o, VoxelBox{lo, lo + 8u});
                    if (t.empty()) continue;
                    ++nonempty;
                    auto at = std::lower_bound(lb.codes.begin(), lb.codes.end(), kdtree::morton3(uvec3(x, y, z)));
                    REQUIRE(at != lb.codes.end());
                    REQUIRE(*at == kdtree::morton3(uvec3(x, y, z)));
                    REQUIRE(lb.boxes[at - lb.codes.begin()] == t);
                }
        REQUIRE(lb.boxes.size() == nonempty);
        REQUIRE(std::is_sorted(lb.codes.begin(), lb.codes.end()));
    }
}

TEST_CASE("local boxes: the Morton range of a box holds all of its blocks", "[svt][local]") {
    SerialExecutor serial;
    Occupancy o = random_occupancy({70, 45, 61}, 0.05, 4);
    kdtree::LocalBoxes lb = kdtree::local_boxes(o, serial);
    std::mt19937 rng(5);
    for (int i = 0; i < 300; ++i) {
        VoxelBox q = random_box(o.dims, rng);
        VoxelBox br = lb.block_range(q);
        std::vector<std::size_t> want, got;
        for (std::size_t k = 0; k < lb.boxes.size(); ++k)
            if (br.contains(lb.boxes[k].lo.x / 8, lb.boxes[k].lo.y / 8, lb.boxes[k].lo.z / 8)) want.push_back(k);
        lb.for_each(q, [&](std::size_t k) { got.push_back(k); });
        REQUIRE(got == want);
        auto [first, last] = lb.morton_range(q);
        for (std::size_t k : want) REQUIRE((k >= first && k < last));
    }
}

TEST_CASE("morton3 interleaves x, y, z from the lowest bit", "[svt][local]") {
    CHECK(kdtree::morton3(uvec3(1, 0, 0)) == 1u);
    CHECK(kdtree::morton3(uvec3(0, 1, 0)) == 2u);
    CHECK(kdtree::morton3(uvec3(0, 0, 1)) == 4u);
    CHECK(kdtree::morton3(uvec3(3, 3, 3)) == 63u);
    CHECK(kdtree::morton3(uvec3(0x1FFFFF, 0, 0)) == 0x1249249249249249ull);
}

TEST_CASE("occupancy: classifying a volume and its density grid agree for every type", "[occupancy]") {
    SerialExecutor serial;
    std::mt19937 rng(3);
    volume::Dims d{13, 7, 5};
    std::size_t n = 13 * 7 * 5;
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        volume::Volume v;
        v.type = type;
        v.dims = d;
        v.bytes.resize(n * volume::scalar_bytes(type));
        for (std::size_t i = 0; i < n; ++i) {
            std::uint32_t r = rng();
            if (type == volume::ScalarType::U8) v.bytes[i] = std::byte(r & 255u);
            if (type == volume::ScalarType::U16) {
                std::uint16_t x = static_cast<std::uint16_t>(r);
                std::memcpy(&v.bytes[2 * i], &x, 2);
            }
            if (type == volume::ScalarType::F32) {
                float x = -3.0f + 7.0f * static_cast<float>(r % 10000) / 10000.0f;
                std::memcpy(&v.bytes[4 * i], &x, 4);
            }
        }
        v.range_lo = type == volume::ScalarType::F32 ? -3.0f : 0.0f;
        v.range_hi = type == volume::ScalarType::F32 ? 4.0f : (type == volume::ScalarType::U8 ? 255.0f : 65535.0f);
        volume::DensityGrid g = volume::normalize(v);
        auto window = [](float d) { return d >= 0.3f && d <= 0.8f; };
        volume::TransferFunctionAlpha alpha(volume::TransferFunction::ramp(0.55f, 0.7f, vec4(1.0f)), 1e-6f);
        check_classifier(v, g, window, serial);
        check_classifier(v, g, alpha, serial);
        check_classifier(v, g, volume::DensityThreshold{0.25f}, serial);
    }
}

TEST_CASE("occupancy: NaN densities and mismatched sizes are errors", "[occupancy]") {
    SerialExecutor serial;
    volume::Volume v;
    v.type = volume::ScalarType::F32;
    v.dims = {2, 2, 1};
    v.bytes.resize(16);
    float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(&v.bytes[8], &nan, 4);
    CHECK_THROWS_AS(volume::classify(volume::classified(v, volume::DensityThreshold{}), serial), Error);
    volume::DensityGrid g{{2, 1, 1}, vec3(1.0f), {0.5f, nan}};
    CHECK_THROWS_AS(volume::count_occupied(volume::classified(g, volume::DensityThreshold{}), serial), Error);
    v.bytes.resize(12);
    CHECK_THROWS_AS(volume::classified(v, volume::DensityThreshold{}), Error);
    volume::Volume zero;
    zero.dims = {0, 4, 4};
    CHECK_THROWS_AS(volume::classified(zero, volume::DensityThreshold{}), Error);
}

TEST_CASE("occupancy: dilation grows by the radius along every axis", "[occupancy]") {
    ThreadPool pool(2);
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        Occupancy o = random_occupancy({17, 12, 9}, 0.01, seed);
        for (std::uint32_t r : {0u, 1u, 2u}) {
            Occupancy d = volume::dilate(o, r, pool);
            for (std::uint32_t z = 0; z < o.dims.z; ++z)
                for (std::uint32_t y = 0; y < o.dims.y; ++y)
                    for (std::uint32_t x = 0; x < o.dims.x; ++x) {
                        uvec3 lo = glm::max(uvec3(x, y, z), uvec3(r)) - uvec3(r);
                        VoxelBox near{lo, uvec3(x, y, z) + r + 1u};
                        REQUIRE(d.at(x, y, z) == (count_direct(o, near) > 0));
                    }
        }
    }
}

// Compile-time checks of the plug-in points: occupancy sources and builder splitters.
namespace {
struct NoRow {
    volume::Dims dims{1};
    vec3 spacing{1.0f};
};
struct UserSource {  // a user's own source: every voxel on the diagonal x == y == z
    volume::Dims dims{4};
    vec3 spacing{1.0f};
    void row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, std::uint8_t* out) const {
        for (std::uint32_t x = x0; x < x1; ++x) out[x - x0] = (x == y && y == z) ? 1u : 0u;
    }
};
static_assert(volume::OccupancySource<Occupancy>);
static_assert(volume::OccupancySource<volume::ClassifiedVolume<volume::DensityThreshold>>);
static_assert(volume::OccupancySource<volume::ClassifiedGrid<volume::TransferFunctionAlpha>>);
static_assert(volume::OccupancySource<UserSource>);
static_assert(!volume::OccupancySource<NoRow>);
static_assert(!volume::OccupancySource<volume::DensityGrid>);
static_assert(!volume::OccupancySource<int>);
}  // namespace

TEST_CASE("occupancy: a user's own source feeds every table", "[occupancy]") {
    SerialExecutor serial;
    UserSource u;
    CHECK(volume::SummedVolumeTable<std::uint32_t>(u).total() == 4u);
    CHECK(volume::PartialSvt<3>(u, serial).tight_box(volume::full_box(u.dims)) == volume::full_box(u.dims));
    CHECK(volume::classify(u, serial).at(2, 2, 2));
    CHECK_FALSE(volume::classify(u, serial).at(2, 1, 2));
}
