// The implicit min/max kd-tree (Wald et al.): node ranges against brute force over the cells
// below each node, the shared iterator's candidate cells against a brute-force list of the
// cells a ray crosses, the encoding against the validator, and bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/ikd/validate.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/shared/cell_dda.h>
#include <sylva/shared/ikd_iter.h>

using namespace sylva;
using Catch::Matchers::Contains;

namespace {

/// A grid of smooth blobs plus noise in [0, 1], so that isosurfaces are neither empty nor full.
volume::DensityGrid blobs(volume::Dims d, std::uint32_t seed, vec3 spacing = vec3(1.0f)) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    vec3 c0(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z), c1(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
    volume::DensityGrid g{d, spacing, std::vector<float>(volume::voxel_count(d))};
    for (std::uint32_t z = 0; z < d.z; ++z)
        for (std::uint32_t y = 0; y < d.y; ++y)
            for (std::uint32_t x = 0; x < d.x; ++x) {
                vec3 p(x, y, z);
                float r = 0.35f * float(std::max({d.x, d.y, d.z}));
                float v = std::exp(-glm::dot(p - c0, p - c0) / (r * r)) + 0.6f * std::exp(-glm::dot(p - c1, p - c1) / (r * r));
                g.values[volume::voxel_index(d, x, y, z)] = std::clamp(0.8f * v + 0.1f * u(rng), 0.0f, 1.0f);
            }
    return g;
}

/// [min, max] of the samples of the real cells in [o, o + 2^w) (brute force).
std::pair<float, float> brute_range(const volume::DensityGrid& g, glm::u32vec3 o, glm::u32vec3 w) {
    glm::u32vec3 cells = g.dims - 1u;
    float lo = 2.0f, hi = -1.0f;
    for (std::uint32_t z = o.z; z <= std::min(o.z + (1u << w.z), cells.z); ++z)
        for (std::uint32_t y = o.y; y <= std::min(o.y + (1u << w.y), cells.y); ++y)
            for (std::uint32_t x = o.x; x <= std::min(o.x + (1u << w.x), cells.x); ++x) {
                lo = std::min(lo, g.at(x, y, z));
                hi = std::max(hi, g.at(x, y, z));
            }
    return {lo, hi};
}

struct Hit {
    glm::u32vec3 cell;
    float t0, t1;
    bool operator<(const Hit& o) const {
        return std::tie(t0, t1, cell.z, cell.y, cell.x) < std::tie(o.t0, o.t1, o.cell.z, o.cell.y, o.cell.x);
    }
    bool operator==(const Hit& o) const { return cell == o.cell && t0 == o.t0 && t1 == o.t1; }
};

struct Encoded {
    volume::DensityGrid grid;
    ikd::Tree tree;
    std::vector<std::uint32_t> words;
    GridWords gw;
    explicit Encoded(volume::DensityGrid g, std::uint32_t brick_levels = ikd::Config{}.brick_levels,
                     std::uint32_t node_bits = ikd::Config{}.node_bits)
        : grid(std::move(g)),
          tree(ikd::build(grid, ikd::Config{brick_levels, node_bits})),
          words(ikd::encode(tree)),
          gw(GridWords::from(grid)) {}
};

/// The iterator's candidate cells of one ray, in the order it yields them.
std::vector<Hit> iterate(const Encoded& e, vec3 o, vec3 d, vec4 isos, std::uint32_t n, float tmax, std::uint32_t* status = nullptr) {
    shared::Words w{e.words.data(), e.words.size()}, g{e.gw.words.data(), e.gw.words.size()};
    shared::SylvaIkdIter it;
    shared::sylva_ikd_init(it, w, static_cast<std::uint32_t>(e.words.size()), static_cast<std::uint32_t>(e.gw.words.size()),
                           o, d, 0.0f, tmax, isos, n);
    std::vector<Hit> out;
    glm::u32vec3 cell;
    float t0, t1;
    while (shared::sylva_ikd_next(it, w, g, cell, t0, t1)) out.push_back({cell, t0, t1});
    if (status) *status = it.status;
    return out;
}

/// The DDA walker's candidate cells of one ray, in its order.
std::vector<Hit> walk(const Encoded& e, vec3 o, vec3 d, vec4 isos, std::uint32_t n, float tmax) {
    shared::Words w{e.words.data(), e.words.size()}, g{e.gw.words.data(), e.gw.words.size()};
    shared::SylvaDdaIter it;
    shared::sylva_dda_init(it, w, static_cast<std::uint32_t>(e.words.size()), static_cast<std::uint32_t>(e.gw.words.size()),
                           o, d, 0.0f, tmax, isos, n);
    std::vector<Hit> out;
    glm::u32vec3 cell;
    float t0, t1;
    while (shared::sylva_dda_next(it, g, cell, t0, t1)) out.push_back({cell, t0, t1});
    REQUIRE(it.status == SYLVA_ITER_DONE);
    return out;
}

/// `hits` without the cells a ray only touches (intervals of length 0).
std::vector<Hit> crossed(std::vector<Hit> hits) {
    hits.erase(std::remove_if(hits.begin(), hits.end(), [](const Hit& h) { return !(h.t0 < h.t1); }), hits.end());
    return hits;
}

/// Every cell the ray crosses (closed boxes, same slab arithmetic as the iterator) whose
/// corner densities span one of the isovalues, sorted by interval.
std::vector<Hit> brute_cells(const Encoded& e, vec3 o, vec3 d, vec4 isos, std::uint32_t n, float tmax) {
    const ikd::Tree& t = e.tree;
    vec3 inv = 1.0f / t.spacing;
    vec3 org = (o - t.origin) * inv, dir = d * inv;
    vec3 rcp(shared::sylva_safe_rcp(dir.x), shared::sylva_safe_rcp(dir.y), shared::sylva_safe_rcp(dir.z));
    glm::u32vec3 par(std::isinf(rcp.x), std::isinf(rcp.y), std::isinf(rcp.z));
    std::vector<Hit> out;
    for (std::uint32_t z = 0; z < t.cells.z; ++z)
        for (std::uint32_t y = 0; y < t.cells.y; ++y)
            for (std::uint32_t x = 0; x < t.cells.x; ++x) {
                vec2 iv = shared::sylva_kd_box_interval_f(org, rcp, par, vec3(x, y, z), vec3(x + 1, y + 1, z + 1), 0.0f, tmax);
                if (!(iv.x <= iv.y)) continue;
                auto [lo, hi] = ikd::detail::cell_range(e.grid, x, y, z);
                if (shared::sylva_ikd_holds(isos, n, lo, hi)) out.push_back({{x, y, z}, iv.x, iv.y});
            }
    std::sort(out.begin(), out.end());
    return out;
}

/// A random ray through (or near) the grid's world box.
std::pair<vec3, vec3> random_ray(std::mt19937& rng, vec3 box) {
    std::uniform_real_distribution<float> inside(0.05f, 0.95f), around(-0.3f, 1.3f), s(-1.0f, 1.0f);
    bool miss_some = rng() % 4 == 0;  // a quarter aim anywhere near the box, the rest through it
    auto pick = [&]() { return miss_some ? around(rng) : inside(rng); };
    vec3 target(pick() * box.x, pick() * box.y, pick() * box.z);
    vec3 dir(s(rng), s(rng), s(rng));
    std::uint32_t flat = rng() % 8;  // some rays parallel to axes, some with -0
    if (flat == 0) dir.x = 0.0f;
    if (flat == 1) dir.y = -0.0f;
    if (flat == 2) dir = vec3(0.0f, 0.0f, 1.0f);
    if (glm::length(dir) < 1e-3f) dir = vec3(0.3f, -0.5f, 0.8f);
    dir = glm::normalize(dir);
    vec3 origin = rng() % 4 == 0 ? target : target - dir * (2.0f * glm::length(box));  // some start inside
    return {origin, dir};
}

}  // namespace

TEST_CASE("ikd levels: one axis per level, virtual padding, counts of real nodes", "[ikd]") {
    ikd::Tree t = ikd::build(blobs({6, 3, 18}, 1), ikd::Config{0});  // 5 x 2 x 17 cells, padded 8 x 2 x 32
    CHECK(t.cells == glm::u32vec3(5, 2, 17));
    CHECK(t.lg == glm::u32vec3(3, 1, 5));
    REQUIRE(t.levels.size() == 9);
    CHECK(t.levels[0].axis == 2);  // z has the most halvings left
    CHECK(t.levels[0].nodes == glm::u32vec3(1, 1, 1));
    CHECK(t.levels[1].nodes == glm::u32vec3(1, 1, 2));  // 17 cells in halves of 16: one real, one partly
    std::size_t stored = 0;
    for (const ikd::Level& l : t.levels) {
        for (int a = 0; a < 3; ++a) CHECK(l.nodes[a] == (t.cells[a] + (1u << l.log2_width[a]) - 1u) >> l.log2_width[a]);
        CHECK(l.first == stored);
        stored += l.count();
    }
    CHECK(t.ranges.size() == stored);
    CHECK(t.levels.back().log2_width[t.levels.back().axis] == 1);  // the last stored level splits into cells
    CHECK(stored < 2 * t.cell_count());  // leaves (cells) are not stored; padding adds partial nodes
    CHECK(t.stored_levels == 9);

    ikd::Tree b = ikd::build(blobs({6, 3, 18}, 1), ikd::Config{3});  // the 3 bottom levels are bricks
    REQUIRE(b.stored_levels == 6);
    std::size_t kept = 0;
    for (std::uint32_t l = 0; l < 6; ++l) kept += b.levels[l].count();
    CHECK(b.ranges.size() == kept);
    for (std::uint32_t l = 6; l < 9; ++l) CHECK(b.levels[l].first == kept);
    CHECK(std::equal(b.ranges.begin(), b.ranges.end(), t.ranges.begin()));  // the same upper levels
    CHECK(kept * 4 < stored);
}

TEST_CASE("ikd node ranges equal brute force over the cells below, rounded outward", "[ikd][parallel]") {
    for (volume::Dims d : {volume::Dims(2, 2, 2), volume::Dims(3, 5, 4), volume::Dims(17, 9, 33), volume::Dims(34, 3, 20),
                           volume::Dims(2, 40, 2), volume::Dims(33, 33, 33)}) {
        volume::DensityGrid g = blobs(d, d.x * 131 + d.y * 7 + d.z);
        SerialExecutor serial;
        ThreadPool pool(2);
        for (std::uint32_t bits : {16u, 8u}) {
            CAPTURE(bits);
            ikd::Tree t = ikd::build(g, serial, ikd::Config{0, bits}), tp = ikd::build(g, pool, ikd::Config{0, bits});
            CHECK(tp.ranges == t.ranges);  // parallel == serial
            // What the encoding holds, read back as the iterators read it (8-bit: half words).
            std::vector<std::uint32_t> words = ikd::encode(t);
            GridWords gw = GridWords::from(g);
            ikd::validate(words, gw.words.size());
            shared::Words w_buf{words.data(), words.size()};
            shared::SylvaIkdHeader hdr = shared::sylva_ikd_read_header(w_buf, static_cast<std::uint32_t>(words.size()),
                                                                        static_cast<std::uint32_t>(gw.words.size()));
            REQUIRE(hdr.valid == 1u);
            CHECK(hdr.format == (bits == 8 ? SYLVA_IKD_FORMAT_UNORM8 : SYLVA_IKD_FORMAT_UNORM16));
            CHECK(words.size() * 4 == t.bytes());
            const double top = bits == 8 ? 255.0 : 65535.0, widen = bits == 8 ? 257.0 : 1.0;
            for (const ikd::Level& l : t.levels)
                for (std::uint32_t k = 0; k < l.nodes.z; ++k)
                    for (std::uint32_t j = 0; j < l.nodes.y; ++j)
                        for (std::uint32_t i = 0; i < l.nodes.x; ++i) {
                            glm::u32vec3 o(i << l.log2_width.x, j << l.log2_width.y, k << l.log2_width.z);
                            auto [lo, hi] = brute_range(g, o, l.log2_width);
                            std::uint32_t index = l.first + i + l.nodes.x * (j + l.nodes.y * k);
                            std::uint32_t w = t.ranges[index];
                            CHECK(shared::sylva_ikd_node_word(w_buf, hdr, index) == w);
                            CHECK((w & 0xFFFFu) == std::uint32_t(std::floor(double(lo) * top) * widen));
                            CHECK((w >> 16) == std::uint32_t(std::ceil(double(hi) * top) * widen));
                            CHECK(shared::sylva_ikd_node_range(w).x <= lo);  // conservative as float too
                            CHECK(shared::sylva_ikd_node_range(w).y >= hi);
                        }
        }
    }
}

TEST_CASE("ikd node words are tested in integer codes exactly as their float ranges", "[ikd]") {
    // sylva_ikd_word_holds(word, codes of v) must equal sylva_ikd_holds(v, node_range(word)) for
    // every code: checked over all 65536 codes per isovalue, at code densities, between them,
    // just beside them (one ulp), at the ends, outside [0, 1] and NaN.
    std::vector<float> isos{0.0f, -0.0f, 1.0f, -1e-30f, 1.0f + 1e-7f, 2.0f, -3.0f, 0.3f, 0.5f,
                            std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::denorm_min()};
    std::mt19937 rng(11);
    std::uniform_int_distribution<std::uint32_t> code(0, 65535);
    for (int i = 0; i < 60; ++i) {
        float c = float(code(rng)) / 65535.0f;
        isos.insert(isos.end(), {c, std::nextafter(c, 0.0f), std::nextafter(c, 1.0f), std::uniform_real_distribution<float>(0, 1)(rng)});
    }
    std::size_t wrong_lo = 0, wrong_hi = 0;
    for (float v : isos) {
        glm::uvec4 at_most, below;
        shared::sylva_ikd_iso_codes(vec4(v, 0.5f, 0.5f, 0.5f), 1u, at_most, below);
        CHECK(at_most.y == 0u);  // isovalues past the count never match
        for (std::uint32_t q = 0; q < 65536u; ++q) {
            float d = float(q) / 65535.0f;
            wrong_lo += (q < at_most.x) != (d <= v);
            wrong_hi += (q >= below.x) != (d >= v);
        }
        vec2 r = shared::sylva_ikd_node_range(0x8000u | (0xC000u << 16));
        CHECK(shared::sylva_ikd_word_holds(0x8000u | (0xC000u << 16), at_most, below) ==
              shared::sylva_ikd_holds(vec4(v, 0, 0, 0), 1u, r.x, r.y));
    }
    CHECK(wrong_lo == 0);
    CHECK(wrong_hi == 0);
}

TEST_CASE("ikd raw-value bounds of uint8 / uint16 grids decide cells exactly as their densities", "[ikd][native]") {
    // For a grid read natively, sylva_ikd_cell_holds tests a cell's raw min / max against
    // sylva_ikd_grid_codes: q < at_most must equal density(q) <= v and q >= below density(q) >= v,
    // for every raw value, over value ranges of the type, narrower, wider and shifted.
    struct Range {
        std::uint32_t format, top;
        float lo, span;
    };
    std::vector<Range> ranges{{SYLVA_GRID_U8, 255u, 0.0f, 255.0f},       {SYLVA_GRID_U8, 255u, 17.0f, 100.0f},
                              {SYLVA_GRID_U8, 255u, -40.0f, 600.0f},     {SYLVA_GRID_U16, 65535u, 0.0f, 65535.0f},
                              {SYLVA_GRID_U16, 65535u, 9000.0f, 42000.0f}, {SYLVA_GRID_U16, 65535u, 1e8f, 3.0f},
                              {SYLVA_GRID_U16, 65535u, -1e8f, 1e8f}};
    std::mt19937 rng(12);
    std::size_t wrong = 0, checked = 0;
    for (const Range& r : ranges) {
        shared::SylvaIkdHeader h{};
        h.grid_format = r.format;
        h.value_lo = r.lo;
        h.value_span = r.span;
        std::vector<float> isos{0.0f, 1.0f, -1.0f, 2.0f, std::numeric_limits<float>::quiet_NaN(), 0.5f};
        std::uniform_int_distribution<std::uint32_t> raw(0, r.top);
        for (int i = 0; i < 40; ++i) {
            float d = shared::sylva_grid_normalise(raw(rng), r.lo, r.span);
            isos.insert(isos.end(), {d, std::nextafter(d, 0.0f), std::nextafter(d, 1.0f)});
        }
        for (float v : isos) {
            glm::uvec4 at_most, below;
            shared::sylva_ikd_grid_codes(h, vec4(v, 0.5f, 0.5f, 0.5f), 1u, at_most, below);
            CHECK(at_most.y == 0u);
            for (std::uint32_t q = 0; q <= r.top; ++q) {
                float d = shared::sylva_grid_normalise(q, r.lo, r.span);
                wrong += (q < at_most.x) != (d <= v);
                wrong += (q >= below.x) != (d >= v);
                ++checked;
            }
        }
    }
    CHECK(wrong == 0);
    CHECK(checked > 1000000);
    shared::SylvaIkdHeader f32{};
    f32.grid_format = SYLVA_GRID_F32;
    glm::uvec4 at_most(7u), below(7u);
    shared::sylva_ikd_grid_codes(f32, vec4(0.5f), 4u, at_most, below);
    CHECK(at_most == glm::uvec4(0u));  // a float32 grid tests its densities directly
}

TEST_CASE("ikd iterator: the candidate cells of brute force, front to back, same intervals", "[ikd]") {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> iso(0.15f, 0.75f);
    std::size_t rays_with_cells = 0;
    for (volume::Dims d : {volume::Dims(2, 2, 2), volume::Dims(3, 5, 4), volume::Dims(17, 9, 33), volume::Dims(20, 20, 12)})
    for (auto [bricks, bits] : {std::pair{0u, 16u}, {0u, 8u}, {3u, 8u}, {4u, 16u}, {6u, 8u}}) {
        // the slim tree, and bricks of 2^3, 2^4 and 4^3 cells; 16- and 8-bit node ranges
        CAPTURE(bricks, bits);
        Encoded e(blobs(d, d.x + 1000 * d.z, vec3(1.0f, 0.75f, 1.5f)), bricks, bits);
        REQUIRE_NOTHROW(ikd::validate(e.words, e.gw.words.size()));
        vec3 box = vec3(d) * e.grid.spacing;
        for (int r = 0; r < 3000; ++r) {
            auto [o, dir] = random_ray(rng, box);
            std::uint32_t n = 1 + rng() % 4;
            vec4 isos(iso(rng), iso(rng), iso(rng), iso(rng));
            float tmax = r % 5 == 0 ? 0.7f * glm::length(box) : 1e30f;  // some rays end inside
            std::uint32_t status = 0;
            std::vector<Hit> got = iterate(e, o, dir, isos, n, tmax, &status);
            REQUIRE(status == SYLVA_ITER_DONE);
            for (std::size_t i = 1; i < got.size(); ++i) REQUIRE(got[i].t0 >= got[i - 1].t0);  // front to back
            std::vector<Hit> want = brute_cells(e, o, dir, isos, n, tmax);
            std::sort(got.begin(), got.end());
            REQUIRE(got.size() == want.size());
            CHECK(got == want);
            rays_with_cells += want.empty() ? 0 : 1;
        }
    }
    CHECK(rays_with_cells > 15000);  // of 60000: the test sees real work
}

TEST_CASE("ikd iterator: culling visits fewer nodes than cells crossed, and an isovalue outside the data none", "[ikd]") {
    Encoded e(blobs({33, 33, 33}, 5));
    vec3 o(-10.0f, 16.8f, 16.3f), d(1.0f, 0.0f, 0.0f);  // passes next to sample (16, 16, 16)
    float iso = e.grid.at(16, 16, 16);
    std::uint32_t status = 0;
    shared::Words w{e.words.data(), e.words.size()}, g{e.gw.words.data(), e.gw.words.size()};
    shared::SylvaIkdIter it;
    shared::sylva_ikd_init(it, w, std::uint32_t(e.words.size()), std::uint32_t(e.gw.words.size()), o, d, 0.0f, 1e30f,
                           vec4(2.0f), 1);
    glm::u32vec3 c;
    float t0, t1;
    CHECK_FALSE(shared::sylva_ikd_next(it, w, g, c, t0, t1));  // density 2 is nowhere: the root is culled
    CHECK(it.steps == 1);
    std::vector<Hit> hits = iterate(e, o, d, vec4(iso), 1, 1e30f, &status);
    CHECK(std::find_if(hits.begin(), hits.end(), [](const Hit& h) { return h.cell == glm::u32vec3(16, 16, 15); }) !=
          hits.end());
    CHECK(status == SYLVA_ITER_DONE);
}

TEST_CASE("ikd bad input: too small, NaN or out-of-range densities, corrupted encodings", "[ikd][errors]") {
    CHECK_THROWS_WITH(ikd::build(blobs({1, 4, 4}, 1)), Contains("every axis needs at least 2"));
    volume::DensityGrid nan = blobs({4, 4, 4}, 1);
    nan.values[17] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(ikd::build(nan), Contains("sample 17 is NaN"));
    volume::DensityGrid big = blobs({4, 4, 4}, 1);
    big.values[3] = 1.5f;
    CHECK_THROWS_WITH(ikd::build(big), Contains("sample 3") && Contains("not a normalised density"));

    Encoded e(blobs({9, 6, 5}, 3));
    const std::size_t gn = e.gw.words.size();
    REQUIRE_NOTHROW(ikd::validate(e.words, gn));
    CHECK_THROWS_WITH(ikd::validate(e.words, gn + 1), Contains("grid buffer holds"));
    auto mutated = [&](std::size_t i, std::uint32_t v) {
        std::vector<std::uint32_t> m = e.words;
        m[i] = v;
        return m;
    };
    CHECK_THROWS_WITH(ikd::validate(mutated(0, 1), gn), Contains("bad magic"));
    CHECK_THROWS_WITH(ikd::validate(mutated(1, 9), gn), Contains("unsupported version"));
    CHECK_THROWS_WITH(ikd::validate(mutated(2, 0), gn), Contains("cells along axis 0"));
    CHECK_THROWS_WITH(ikd::validate(mutated(2, 9), gn), Contains("padding"));
    CHECK_THROWS_WITH(ikd::validate(mutated(5, e.words[5] + 1), gn), Contains("levels"));
    CHECK_THROWS_WITH(ikd::validate(mutated(6, e.words[6] + 1), gn), Contains("nodes stored"));
    CHECK_THROWS_WITH(ikd::validate(mutated(7, 2), gn), Contains("node format"));
    CHECK_THROWS_WITH(ikd::validate(mutated(7, e.words[7] ^ 1u), gn), Contains("nodes stored"));  // 8 <-> 16 bits
    CHECK_THROWS_WITH(ikd::validate(mutated(7, 0x10000u), gn), Contains("node format"));
    CHECK_THROWS_WITH(ikd::validate(mutated(7, 60u << 8), gn), Contains("stored levels"));
    CHECK_THROWS_WITH(ikd::validate(mutated(7, e.words[7] - (1u << 8)), gn), Contains("level table"));
    CHECK_THROWS_WITH(ikd::validate(mutated(10, std::bit_cast<std::uint32_t>(-1.0f)), gn), Contains("spacing"));
    CHECK_THROWS_WITH(ikd::validate(mutated(16, 5), gn), Contains("truncated or padded"));
    CHECK_THROWS_WITH(ikd::validate(mutated(20, e.words[20] ^ 3u), gn), Contains("level table"));
    CHECK_THROWS_WITH(ikd::validate(mutated(21, 1), gn), Contains("level table"));
    CHECK_THROWS_WITH(ikd::validate(mutated(e.words.size() - 1, 0x000000FFu), gn), Contains("min above max"));  // 8-bit: min 255, max 0
    std::vector<std::uint32_t> cut(e.words.begin(), e.words.end() - 1);
    CHECK_THROWS_WITH(ikd::validate(cut, gn), Contains("truncated"));
    // 8-bit nodes, two a word: an odd count leaves half of the last word unused, and it must be 0.
    REQUIRE(e.tree.node_bits == 8);
    REQUIRE(e.words[6] % 2 == 1);
    CHECK_THROWS_WITH(ikd::validate(mutated(e.words.size() - 1, e.words.back() | 0x01000000u), gn),
                      Contains("unused half"));
    Encoded e16(blobs({9, 6, 5}, 3), ikd::Config{}.brick_levels, 16);
    REQUIRE_NOTHROW(ikd::validate(e16.words, gn));
    CHECK(e16.words.size() - 20 - 2 * (e16.words[5] & 255u) == 2 * (e.words.size() - 20 - 2 * (e.words[5] & 255u)) - 1);
    std::vector<std::uint32_t> m16 = e16.words;
    m16.back() = 0x0000FFFFu;
    CHECK_THROWS_WITH(ikd::validate(m16, gn), Contains("min above max"));

    // Whatever a header word holds, the iterator either refuses the encoding (ERROR) or runs to
    // the end without reading outside the buffers (the host's Words checks every load).
    std::mt19937 rng(9);
    for (int trial = 0; trial < 4000; ++trial) {
        std::vector<std::uint32_t> m = e.words;
        std::size_t i = rng() % m.size();
        m[i] ^= 1u << (rng() % 32);
        shared::Words w{m.data(), m.size()}, g{e.gw.words.data(), e.gw.words.size()};
        shared::SylvaIkdIter it;
        shared::sylva_ikd_init(it, w, std::uint32_t(m.size()), std::uint32_t(gn), vec3(-3.0f, 2.5f, 2.2f),
                               glm::normalize(vec3(1.0f, 0.1f, 0.05f)), 0.0f, 1e30f, vec4(0.4f), 1);
        glm::u32vec3 c;
        float t0, t1;
        std::size_t n = 0;
        while (shared::sylva_ikd_next(it, w, g, c, t0, t1)) {
            REQUIRE(c.x < 8);
            REQUIRE(c.y < 5);
            REQUIRE(c.z < 4);
            REQUIRE(++n <= 8 * 5 * 4);
        }
        bool valid = true;
        try {
            ikd::validate(m, gn);
        } catch (const Error&) {
            valid = false;
        }
        if (!valid && i < 20 + 2 * (e.words[5] & 255u)) CHECK(it.status == SYLVA_ITER_ERROR);  // header refused
    }
}

TEST_CASE("cell DDA: the candidate cells of brute force in order, with the tree's intervals", "[ikd][dda]") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> iso(0.15f, 0.75f);
    std::size_t compared = 0;
    for (volume::Dims d : {volume::Dims(2, 2, 2), volume::Dims(3, 5, 4), volume::Dims(17, 9, 33), volume::Dims(20, 20, 12)}) {
        Encoded e(blobs(d, d.y + 77 * d.z, vec3(0.5f, 1.0f, 2.0f)));
        vec3 box = vec3(d) * e.grid.spacing;
        for (int r = 0; r < 3000; ++r) {
            auto [o, dir] = random_ray(rng, box);
            std::uint32_t n = 1 + rng() % 4;
            vec4 isos(iso(rng), iso(rng), iso(rng), iso(rng));
            float tmax = r % 5 == 0 ? 0.7f * glm::length(box) : 1e30f;
            std::vector<Hit> got = walk(e, o, dir, isos, n, tmax);
            for (std::size_t i = 1; i < got.size(); ++i) REQUIRE(got[i].t0 >= got[i - 1].t0);
            std::vector<Hit> want = crossed(brute_cells(e, o, dir, isos, n, tmax));
            std::vector<Hit> tree = crossed(iterate(e, o, dir, isos, n, tmax));
            got = crossed(got);
            REQUIRE(got.size() == want.size());
            std::vector<Hit> sorted = got;
            std::sort(sorted.begin(), sorted.end());
            CHECK(sorted == want);
            CHECK(got == tree);  // the same cells as the tree, in the same order, same intervals
            compared += got.size();
        }
    }
    CHECK(compared > 20000);
}
