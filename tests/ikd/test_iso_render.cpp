// Exact isosurface rendering (sylva/render/iso.hpp): the implicit kd-tree and the reference cell
// DDA give identical images hit for hit, hits against closed forms, uint8 / uint16 grids read
// natively equal to their float32 copy, and the bad cases.
#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <random>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/volume/procedural.hpp>

#include "quantised.hpp"

using namespace sylva;
using Catch::Matchers::Contains;

namespace {

struct Scene {
    volume::DensityGrid grid;
    std::vector<std::uint32_t> words;
    GridWords gw;
    explicit Scene(volume::DensityGrid g) : grid(std::move(g)), words(ikd::encode(ikd::build(grid))), gw(GridWords::from(grid)) {}
};

IsoRenderParams params_for(const Scene& s, std::vector<IsoSurface> isos, std::uint32_t w = 96, std::uint32_t h = 72) {
    IsoRenderParams p;
    p.width = w;
    p.height = h;
    p.camera = Camera::framing(s.grid.world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(w, h);
    p.isos = std::move(isos);
    return p;
}

std::vector<std::uint32_t> bits_of(const Frame& f) {
    std::vector<std::uint32_t> out;
    for (const vec4& c : f.rgba)
        for (int k = 0; k < 4; ++k) out.push_back(std::bit_cast<std::uint32_t>(c[k]));
    return out;
}

}  // namespace

TEST_CASE("iso rendering: the implicit kd-tree's image equals the cell DDA's, hit for hit", "[ikd][iso]") {
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        std::vector<IsoSurface> isos;
    };
    std::vector<Case> cases;
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {{0.5f, vec4(0.9f, 0.8f, 0.6f, 1.0f)}}});
    cases.push_back({volume::marschner_lobb({33, 20, 27}),
                     {{0.3f, vec4(0.2f, 0.6f, 0.9f, 0.35f)}, {0.6f, vec4(0.9f, 0.4f, 0.2f, 0.5f)}, {0.8f, vec4(1.0f)}}});
    cases.push_back({volume::radial_falloff({19, 7, 33}, vec3(9.5f, 3.0f, 16.5f), 15.0f, vec3(1.0f, 2.0f, 0.5f)),
                     {{0.25f, vec4(0.7f, 0.9f, 0.7f, 0.4f)}, {0.5f, vec4(0.9f)}, {0.7f, vec4(1.0f, 0.2f, 0.2f, 0.6f)},
                      {0.9f, vec4(1.0f)}}});
    for (Case& c : cases) {
        Scene s(c.grid);
        IsoRenderParams p = params_for(s, c.isos);
        IsoCounters tree_n, dda_n;
        Frame tree = render_iso_cpu(s.words, s.gw, p, pool, &tree_n);
        p.walker = IsoWalker::Dda;
        Frame dda = render_iso_cpu(s.words, s.gw, p, pool, &dda_n);
        CHECK(bits_of(tree) == bits_of(dda));
        CHECK(tree_n.hits == dda_n.hits);
        CHECK(tree_n.cells == dda_n.cells);  // the same candidate cells were intersected
        CHECK(tree_n.hits > 1000);
        CHECK(tree_n.errors == 0);
        std::size_t visible = 0;
        for (const vec4& px : tree.rgba) visible += px.w > 0.0f ? 1u : 0u;
        CHECK(visible > tree.rgba.size() / 10);
    }
}

TEST_CASE("iso rendering: a linear ramp's isosurface is the plane where the ramp crosses it", "[ikd][iso]") {
    const std::uint32_t n = 17;
    volume::DensityGrid g{{n, 9, 6}, vec3(0.5f, 1.0f, 1.0f), std::vector<float>(n * 9 * 6)};
    for (std::uint32_t z = 0; z < 6; ++z)
        for (std::uint32_t y = 0; y < 9; ++y)
            for (std::uint32_t x = 0; x < n; ++x) g.values[volume::voxel_index(g.dims, x, y, z)] = float(x) / float(n - 1);
    Scene s(g);
    IsoRenderParams p = params_for(s, {{0.3f, vec4(0.5f, 1.0f, 0.25f, 1.0f)}});
    std::vector<std::uint32_t> params = iso_params(p, s.words.size(), s.gw.words.size());
    shared::Words pw{params.data(), params.size()}, tw{s.words.data(), s.words.size()}, gw{s.gw.words.data(), s.gw.words.size()};
    shared::SylvaIsoParams sp = shared::sylva_iso_read_params(pw);
    for (float yz : {2.1f, 4.5f, 6.7f}) {
        for (vec3 dir : {vec3(1.0f, 0.0f, 0.0f), glm::normalize(vec3(1.0f, 0.2f, -0.1f))}) {
            vec3 eye(-3.0f, yz, 3.0f);
            shared::SylvaIkdHeader hdr = shared::sylva_ikd_read_header(tw, sp.tree_words, sp.grid_words);
            shared::SylvaIsoRay tree = shared::sylva_iso_trace(tw, gw, sp, hdr, eye, dir);
            sp.walker = SYLVA_ISO_WALK_DDA;
            shared::SylvaIsoRay dda = shared::sylva_iso_trace(tw, gw, sp, hdr, eye, dir);
            sp.walker = SYLVA_ISO_WALK_TREE;
            INFO("yz " << yz << " dir " << dir.x << " cells " << tree.cells << " steps " << tree.steps << " status " << tree.status);
            REQUIRE(tree.hits == 1);
            CHECK(dda.hits == 1);
            // Opaque, facing the plane's normal (x) by dir.x: colour * (ambient + diffuse * |cos|).
            float shade = 0.25f + 0.75f * std::fabs(dir.x);
            CHECK(tree.rgba.x == Approx(0.5 * shade).margin(3e-3));
            CHECK(tree.rgba.y == Approx(1.0 * shade).margin(3e-3));
            CHECK(tree.rgba.w == 1.0f);
            CHECK(std::bit_cast<std::uint32_t>(tree.rgba.x) == std::bit_cast<std::uint32_t>(dda.rgba.x));
            // Only the cells holding the plane (density 0.3 at sample 4.8) are candidates.
            CHECK(tree.cells == 1);
            CHECK(dda.cells == 1);
        }
    }
}

TEST_CASE("iso rendering: the hit distance of a ray along the ramp is exact", "[ikd][iso]") {
    const std::uint32_t n = 17;
    volume::DensityGrid g{{n, 3, 3}, vec3(0.5f, 1.0f, 1.0f), std::vector<float>(n * 9)};
    for (std::uint32_t z = 0; z < 3; ++z)
        for (std::uint32_t y = 0; y < 3; ++y)
            for (std::uint32_t x = 0; x < n; ++x) g.values[volume::voxel_index(g.dims, x, y, z)] = float(x) / float(n - 1);
    Scene s(g);
    // A semi-transparent surface lets the ray go on: its colour tells the hit happened once.
    IsoRenderParams p = params_for(s, {{0.3f, vec4(1.0f, 1.0f, 1.0f, 0.5f)}});
    std::vector<std::uint32_t> params = iso_params(p, s.words.size(), s.gw.words.size());
    shared::Words pw{params.data(), params.size()}, tw{s.words.data(), s.words.size()}, gw{s.gw.words.data(), s.gw.words.size()};
    shared::SylvaIsoParams sp = shared::sylva_iso_read_params(pw);
    shared::SylvaIsoRay r = shared::sylva_iso_trace(tw, gw, sp, shared::sylva_ikd_read_header(tw, sp.tree_words, sp.grid_words),
                                                    vec3(-3.0f, 1.2f, 1.3f), vec3(1.0f, 0.0f, 0.0f));
    CHECK(r.hits == 1);
    CHECK(r.rgba.w == Approx(128.0 / 255.0));  // opacity 0.5 as RGBA8
    // The t of the hit, through the shared iterator and cell intersection directly.
    shared::SylvaIkdIter it;
    shared::sylva_ikd_init(it, tw, sp.tree_words, sp.grid_words, vec3(-3.0f, 1.2f, 1.3f), vec3(1.0f, 0.0f, 0.0f), 0.0f,
                           1e30f, vec4(0.3f), 1);
    glm::u32vec3 cell;
    float t0, t1, th = 0.0f;
    bool hit = false;
    while (!hit && shared::sylva_ikd_next(it, tw, gw, cell, t0, t1)) {
        vec3 o = it.org - vec3(cell);
        hit = shared::sylva_iso_cell_hit(it.corners_lo, it.corners_hi, o, vec3(2.0f, 0.0f, 0.0f), t0, t1, 0.3f, th);
    }
    REQUIRE(hit);
    CHECK(th == Approx(3.0 + (0.3 * 16.0 + 0.5) * 0.5).epsilon(1e-6));
}

TEST_CASE("iso rendering: isovalues outside the data give an empty image; bad parameters are refused", "[ikd][iso][errors]") {
    ThreadPool pool(2);
    Scene s(volume::marschner_lobb({21, 21, 21}));
    IsoRenderParams p = params_for(s, {{1.5f, vec4(1.0f)}}, 32, 24);
    IsoCounters n;
    Frame f = render_iso_cpu(s.words, s.gw, p, pool, &n);
    for (const vec4& c : f.rgba) CHECK(c.w == 0.0f);
    CHECK(n.cells == 0);
    CHECK(n.hits == 0);
    p.isos.clear();
    CHECK_THROWS_WITH(render_iso_cpu(s.words, s.gw, p, pool), Contains("1 to 4"));
    p.isos = std::vector<IsoSurface>(5);
    CHECK_THROWS_WITH(render_iso_cpu(s.words, s.gw, p, pool), Contains("1 to 4"));
    p.isos = {{std::nanf(""), vec4(1.0f)}};
    CHECK_THROWS_WITH(render_iso_cpu(s.words, s.gw, p, pool), Contains("not finite"));
    // A corrupted header: every pixel reports the error, nothing is drawn.
    std::vector<std::uint32_t> bad = s.words;
    bad[0] = 0;
    p.isos = {{0.5f, vec4(1.0f)}};
    f = render_iso_cpu(bad, s.gw, p, pool, &n);
    CHECK(n.errors == std::uint64_t{32} * 24);
    for (const vec4& c : f.rgba) CHECK(c.w == 0.0f);
}

TEST_CASE("iso rendering: packets of 4, 8 and 16 rays give the single-ray image bit for bit, in fewer steps",
          "[ikd][iso][packet]") {
    ThreadPool pool(2);
    const PacketLanes widths[] = {PacketLanes::Four, PacketLanes::Eight, PacketLanes::Sixteen};
    for (std::uint32_t bricks : {0u, 6u}) {
        volume::DensityGrid g = volume::marschner_lobb({41, 37, 29});
        std::vector<std::uint32_t> words = ikd::encode(ikd::build(g, ikd::Config{bricks}));
        GridWords gw = GridWords::from(g);
        for (RaySource source : {RaySource::Pinhole, RaySource::Ortho}) {
            IsoRenderParams p;
            p.width = 97;  // odd sizes: partial tiles at the right and bottom edges
            p.height = 71;
            Camera cam = Camera::framing(g.world_box(), vec3(0.4f, 0.3f, 1.0f));
            p.camera = source == RaySource::Ortho ? cam.ortho_frame(p.width, p.height, 0.5f * glm::length(g.world_box().extent()))
                                                  : cam.frame(p.width, p.height);
            p.rays.source = source;  // the packets compute these rays four lanes at a time
            p.isos = {{0.3f, vec4(0.2f, 0.6f, 0.9f, 0.35f)}, {0.6f, vec4(0.9f, 0.8f, 0.6f, 1.0f)}};
            IsoCounters single_n;
            Frame single = render_iso_cpu(words, gw, p, pool, &single_n);
            REQUIRE(single_n.hits > 100u);
            std::uint64_t previous_steps = single_n.steps;
            for (PacketLanes lanes : widths) {
                INFO("bricks " << bricks << ", ortho " << (source == RaySource::Ortho) << ", lanes " << std::uint32_t(lanes));
                IsoCounters packet_n;
                Frame packet = render_iso_cpu_packets(words, gw, p, pool, &packet_n, lanes);
                CHECK(bits_of(single) == bits_of(packet));
                CHECK(single_n.cells == packet_n.cells);
                CHECK(single_n.hits == packet_n.hits);
                CHECK(packet_n.steps < previous_steps);  // wider packets: fewer steps
                CHECK(packet_n.steps * std::uint32_t(lanes) >= single_n.steps);  // at most `lanes` rays share a step
                // Each active lane of a packet step is one of the single rays' steps.
                CHECK(packet_n.lane_steps == single_n.steps);
                CHECK(packet_n.lane_steps > packet_n.steps);
                previous_steps = packet_n.steps;
            }
        }
    }
    // A camera inside the volume: the directions of a tile differ in sign and fall back to single rays.
    volume::DensityGrid g = volume::marschner_lobb({21, 21, 21});
    std::vector<std::uint32_t> words = ikd::encode(ikd::build(g));
    GridWords gw = GridWords::from(g);
    IsoRenderParams p;
    p.width = 32;
    p.height = 32;
    p.camera = Camera{vec3(10.5f), vec3(10.5f, 10.5f, 20.0f), vec3(0.0f, 1.0f, 0.0f), 90.0f}.frame(32, 32);
    p.isos = {{0.5f, vec4(1.0f)}};
    for (PacketLanes lanes : widths)
        CHECK(bits_of(render_iso_cpu(words, gw, p, pool)) == bits_of(render_iso_cpu_packets(words, gw, p, pool, nullptr, lanes)));
    CHECK_THROWS_WITH(render_iso_cpu_packets(words, gw, p, pool, nullptr, static_cast<PacketLanes>(3)),
                      Catch::Contains("packets hold 4, 8 or 16 rays, not 3"));
}

namespace {

struct LaneCell {
    glm::u32vec3 cell;
    std::uint32_t t0, t1;  // bits
    bool operator==(const LaneCell&) const = default;
};

/// The single-ray iterator's candidate cells of one ray, with their interval bits.
std::vector<LaneCell> single_cells(const std::vector<std::uint32_t>& words, const GridWords& gw,
                                   const shared::SylvaIkdHeader& hdr, vec3 o, vec3 d, float t0, float t1, vec4 isos) {
    shared::Words tw{words.data(), words.size()}, g{gw.words.data(), gw.words.size()};
    shared::SylvaIkdIter it;
    shared::sylva_ikd_begin(it, hdr, o, d, t0, t1, isos, 2u);
    std::vector<LaneCell> out;
    glm::u32vec3 c;
    float a, b;
    while (shared::sylva_ikd_next(it, tw, g, c, a, b)) out.push_back({c, std::bit_cast<std::uint32_t>(a), std::bit_cast<std::uint32_t>(b)});
    return out;
}

}  // namespace

namespace {

/// Packets of L lanes against the single-ray iterator, lane by lane (see the test below).
template <int L>
void check_packet_lanes() {
    volume::DensityGrid g = volume::marschner_lobb({23, 17, 30});
    GridWords gw = GridWords::from(g);
    const vec4 isos(0.3f, 0.6f, 0.0f, 0.0f);
    std::mt19937 rng(5 + L);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::size_t lanes_checked = 0, parallel_lanes = 0, cells_seen = 0;
    for (std::uint32_t bricks : {0u, 6u}) {
        std::vector<std::uint32_t> words = ikd::encode(ikd::build(g, ikd::Config{bricks}));
        shared::SylvaIkdHeader hdr = shared::sylva_ikd_read_header(shared::Words{words.data(), words.size()},
                                                                    static_cast<std::uint32_t>(words.size()),
                                                                    static_cast<std::uint32_t>(gw.words.size()));
        REQUIRE(hdr.valid == 1u);
        vec3 cells(hdr.cells);
        for (int n = 0; n < 12000 / L; ++n) {  // 3,000 packets of 4, fewer of more lanes
            ikd::BasicRayPacket<L> pk;
            glm::bvec3 negative(u(rng) < 0.5f, u(rng) < 0.5f, u(rng) < 0.5f);
            for (int k = 0; k < L; ++k) {
                if (u(rng) < 0.1f) continue;  // inactive lane
                pk.active |= 1u << k;
                vec3 cell_o(u(rng) * 1.4f - 0.2f, u(rng) * 1.4f - 0.2f, u(rng) * 1.4f - 0.2f);
                cell_o *= cells;
                for (int a = 0; a < 3; ++a)
                    if (u(rng) < 0.3f) cell_o[a] = std::floor(cell_o[a]);  // on a cell plane
                pk.origin[k] = hdr.origin + cell_o / hdr.inv_spacing;
                for (int a = 0; a < 3; ++a) {
                    float m = u(rng) < 0.2f ? 0.0f : 0.05f + u(rng);
                    pk.direction[k][a] = negative[a] ? -m : m;  // -0.0f on a negative axis: same sign bit
                }
                if (pk.direction[k] == vec3(0.0f)) pk.direction[k].x = negative.x ? -1.0f : 1.0f;
                parallel_lanes += pk.direction[k].x == 0.0f || pk.direction[k].y == 0.0f || pk.direction[k].z == 0.0f;
                pk.t_min[k] = u(rng) < 0.2f ? u(rng) * 10.0f : 0.0f;
                pk.t_max[k] = u(rng) < 0.2f ? pk.t_min[k] + u(rng) * 30.0f : shared::sylva_inf();
            }
            REQUIRE(ikd::same_signs(pk));
            ikd::BasicPacketIter<L> it(words, gw.words, hdr, pk, isos, 2u);
            std::array<std::vector<LaneCell>, L> got;
            ikd::BasicPacketCell<L> c;
            while (it.next(c))
                for (int k = 0; k < L; ++k)
                    if (c.mask >> k & 1u)
                        got[k].push_back({c.cell, std::bit_cast<std::uint32_t>(c.t0[k]), std::bit_cast<std::uint32_t>(c.t1[k])});
            REQUIRE(it.status() == SYLVA_ITER_DONE);
            for (int k = 0; k < L; ++k) {
                if (!(pk.active >> k & 1u)) {
                    CHECK(got[k].empty());
                    continue;
                }
                std::vector<LaneCell> want = single_cells(words, gw, hdr, pk.origin[k], pk.direction[k], pk.t_min[k], pk.t_max[k], isos);
                CHECK(got[k] == want);
                ++lanes_checked;
                cells_seen += want.size();
            }
        }
    }
    CHECK(lanes_checked > 15000);
    CHECK(parallel_lanes > 5000);
    CHECK(cells_seen > 10000);
}

}  // namespace

TEST_CASE("ikd packets: each lane's cells and interval bits are its single ray's, parallel lanes included", "[ikd][packet]") {
    // Rays of one sign pattern, some lanes with +-0 direction components (parallel to an axis:
    // the lane keeps its interval on its side of each split plane), origins on cell planes,
    // inside and outside the grid, inactive lanes; odd dims, the slim and the bricked tree;
    // packets of 4, 8 and 16 rays.
    check_packet_lanes<4>();
    check_packet_lanes<8>();
    check_packet_lanes<16>();
}

TEST_CASE("iso rendering: uint8 and uint16 grids read natively give the float32 grid's image, hit for hit",
          "[ikd][iso][native]") {
    ThreadPool pool(2);
    volume::DensityGrid field = volume::marschner_lobb({33, 20, 27});
    struct Case {
        volume::ScalarType type;
        float lo, hi;
    };
    for (Case c : {Case{volume::ScalarType::U8, 0.0f, 255.0f}, Case{volume::ScalarType::U16, 0.0f, 65535.0f},
                   Case{volume::ScalarType::U16, 9000.0f, 51000.0f}}) {
        volume::Volume v = test::quantised(field, c.type, c.lo, c.hi);
        volume::DensityGrid g = volume::normalize(v);  // what the tree is built from
        std::vector<std::uint32_t> words = ikd::encode(ikd::build(g, ikd::Config{4}));
        GridWords f32 = GridWords::from(g), native = GridWords::native(v);
        INFO("format " << static_cast<int>(native.sampling.format) << " range " << c.lo << ".." << c.hi);
        REQUIRE(native.grid_bytes() == g.values.size() * volume::scalar_bytes(c.type));
        REQUIRE(native.words.size() * 4 < f32.words.size() * 4 / (c.type == volume::ScalarType::U8 ? 3 : 1.9));
        Scene s(g);
        IsoRenderParams p = params_for(s, {{0.3f, vec4(0.2f, 0.6f, 0.9f, 0.35f)}, {0.6f, vec4(0.9f, 0.4f, 0.2f, 0.5f)},
                                           {0.8f, vec4(1.0f)}});
        IsoCounters nf, nn;
        Frame want = render_iso_cpu(words, f32, p, pool, &nf);
        Frame got = render_iso_cpu(words, native, p, pool, &nn);
        CHECK(bits_of(got) == bits_of(want));
        CHECK(nn.cells == nf.cells);
        CHECK(nn.hits == nf.hits);
        CHECK(nn.steps == nf.steps);
        CHECK(nn.errors == 0);
        CHECK(nf.hits > 1000);
        IsoCounters np;
        CHECK(bits_of(render_iso_cpu_packets(words, native, p, pool, &np)) == bits_of(want));
        CHECK(np.cells == nf.cells);
        p.walker = IsoWalker::Dda;
        IsoCounters nd;
        CHECK(bits_of(render_iso_cpu(words, native, p, pool, &nd)) == bits_of(want));
        CHECK(nd.cells == nf.cells);
    }
}

TEST_CASE("iso rendering: the header reader checks a native grid's format, range and word count", "[ikd][iso][native][errors]") {
    volume::DensityGrid field = volume::marschner_lobb({9, 6, 7});  // 378 samples: 94.5 uint8 words
    volume::Volume v = test::quantised(field, volume::ScalarType::U8, 0.0f, 255.0f);
    std::vector<std::uint32_t> words = ikd::encode(ikd::build(volume::normalize(v)));
    GridWords native = GridWords::native(v);
    REQUIRE(native.words.size() == 95);
    shared::Words tw{words.data(), words.size()};
    auto wc = static_cast<std::uint32_t>(words.size());
    auto valid = [&](std::uint32_t grid_words, std::uint32_t format, float lo, float span) {
        return shared::sylva_ikd_read_header_grid(tw, wc, grid_words, format, lo, span).valid;
    };
    CHECK(valid(95, SYLVA_GRID_U8, 0.0f, 255.0f) == 1u);
    CHECK(valid(189, SYLVA_GRID_U16, 0.0f, 255.0f) == 1u);
    CHECK(valid(378, SYLVA_GRID_F32, 0.0f, 1.0f) == 1u);
    CHECK(valid(94, SYLVA_GRID_U8, 0.0f, 255.0f) == 0u);   // truncated
    CHECK(valid(96, SYLVA_GRID_U8, 0.0f, 255.0f) == 0u);   // too long
    CHECK(valid(378, SYLVA_GRID_U8, 0.0f, 255.0f) == 0u);  // float32 words as uint8
    CHECK(valid(95, SYLVA_GRID_SPARSE_U8, 0.0f, 255.0f) == 0u);
    CHECK(valid(95, 7u, 0.0f, 255.0f) == 0u);
    CHECK(valid(95, SYLVA_GRID_U8, 0.0f, 0.0f) == 0u);  // empty range
    CHECK(valid(95, SYLVA_GRID_U8, 0.0f, -1.0f) == 0u);
    CHECK(valid(95, SYLVA_GRID_U8, std::nanf(""), 255.0f) == 0u);
    CHECK(valid(95, SYLVA_GRID_U8, 0.0f, std::numeric_limits<float>::infinity()) == 0u);
    // The renderer refuses them with a message before any ray.
    ThreadPool pool(1);
    IsoRenderParams p;
    p.width = p.height = 8;
    p.camera = Camera::framing(field.world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(8, 8);
    GridWords cut = native;
    cut.words.pop_back();
    CHECK_THROWS_WITH(render_iso_cpu(words, cut, p, pool), Contains("GridWords holds 94 words") && Contains("95 expected"));
    GridWords empty_range = native;
    empty_range.sampling.value_span = 0.0f;
    CHECK_THROWS_WITH(render_iso_cpu(words, empty_range, p, pool), Contains("value range"));
    // A grid of other dims (the float32 grid's word count for another tree): every ray reports
    // the refused header.
    volume::Volume other = test::quantised(volume::marschner_lobb({9, 6, 8}), volume::ScalarType::U8, 0.0f, 255.0f);
    IsoCounters n;
    render_iso_cpu(words, GridWords::native(other), p, pool, &n);
    CHECK(n.errors == 64);
}

namespace {

/// The first hit of isovalue `iso` along (eye, dir) in the shell cells before the grid
/// (sylva/shared/iso_shell.h), through the shared walker and cell intersection directly.
bool first_shell_hit(const Scene& s, float border, vec3 eye, vec3 dir, float iso, float& th) {
    shared::Words tw{s.words.data(), s.words.size()}, gw{s.gw.words.data(), s.gw.words.size()};
    shared::SylvaShellIter sh;
    shared::sylva_shell_begin(sh, shared::sylva_ikd_read_header(tw, tw.size, gw.size), eye, dir, 0.0f, 1e30f, vec4(iso), 1,
                              border, 0x3Fu);
    vec3 cmin;
    float t0, t1;
    while (shared::sylva_shell_next(sh, gw, cmin, t0, t1))
        if (shared::sylva_iso_cell_hit(sh.corners_lo, sh.corners_hi, sh.org - cmin, sh.d, t0, t1, iso, th)) return true;
    return false;
}

/// `g` padded by one layer of samples of value `b` on every face: the grid a constant border
/// makes explicit.
volume::DensityGrid padded(const volume::DensityGrid& g, float b) {
    volume::Dims d{g.dims.x + 2, g.dims.y + 2, g.dims.z + 2};
    volume::DensityGrid out{d, g.spacing, std::vector<float>(std::size_t{d.x} * d.y * d.z, b)};
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x)
                out.values[volume::voxel_index(d, x + 1, y + 1, z + 1)] = g.at(x, y, z);
    return out;
}

}  // namespace

TEST_CASE("iso rendering: a constant border closes surfaces at the faces; a uniform grid's surface is its world box",
          "[ikd][iso][border]") {
    ThreadPool pool(2);
    for (float inside : {1.0f, 0.0f}) {
        const float border = 1.0f - inside;
        volume::DensityGrid g{{9, 7, 11}, vec3(1.0f, 0.5f, 1.5f), std::vector<float>(9 * 7 * 11, inside)};
        Scene s(g);
        const vec3 top = vec3(g.dims) * g.spacing;  // the world box [0, top]: samples at (i + 0.5) spacing
        INFO("inside " << inside << " border " << border);
        // Without a border the grid's cells hold no crossing: nothing is drawn.
        IsoRenderParams p = params_for(s, {{0.5f, vec4(1.0f)}}, 40, 30);
        IsoCounters n;
        render_iso_cpu(s.words, s.gw, p, pool, &n);
        CHECK(n.hits == 0);
        // With it, the density 0.5 lies half way between the face samples and the border's: on
        // the world box. The hit t of rays from outside, exact to rounding.
        float th = 0.0f;
        REQUIRE(first_shell_hit(s, border, vec3(-3.0f, 1.7f, 5.1f), vec3(1.0f, 0.0f, 0.0f), 0.5f, th));
        CHECK(th == Approx(3.0f).epsilon(1e-6));
        REQUIRE(first_shell_hit(s, border, vec3(4.2f, 2.3f, top.z + 2.5f), vec3(0.0f, 0.0f, -1.0f), 0.5f, th));
        CHECK(th == Approx(2.5f).epsilon(1e-6));
        vec3 dir = glm::normalize(vec3(0.3f, 1.0f, 0.2f));
        vec3 eye = vec3(4.0f, 0.0f, 7.0f) - 2.0f * dir;  // enters through the y = 0 face at t = 2
        REQUIRE(first_shell_hit(s, border, eye, dir, 0.5f, th));
        CHECK(th == Approx(2.0f).epsilon(1e-5));
        // The whole frame, orthographic down -z: a pixel is opaque where its ray crosses the box's
        // footprint, transparent elsewhere, and white (facing the z face) well inside it.
        p.border = border;
        p.rays.source = RaySource::Ortho;
        p.width = 64;
        p.height = 48;
        vec3 c = 0.5f * top;
        p.camera = CameraFrame{vec3(c.x, c.y, top.z + 5.0f), vec3(0.0f, 0.0f, -1.0f), vec3(8.0f, 0.0f, 0.0f),
                               vec3(0.0f, 6.0f, 0.0f)};
        Frame f = render_iso_cpu(s.words, s.gw, p, pool, &n);
        CHECK(n.errors == 0);
        std::size_t checked = 0;
        for (std::uint32_t y = 0; y < p.height; ++y) {
            for (std::uint32_t x = 0; x < p.width; ++x) {
                float wx = c.x + ((x + 0.5f) / p.width * 2.0f - 1.0f) * 8.0f;
                float wy = c.y + (1.0f - (y + 0.5f) / p.height * 2.0f) * 6.0f;
                float edge = std::min(std::min(wx, top.x - wx), std::min(wy, top.y - wy));  // < 0 outside
                // Within half a voxel of two faces the trilinear surface rounds the box's edge off.
                float dx = std::min(wx, top.x - wx) / g.spacing.x, dy = std::min(wy, top.y - wy) / g.spacing.y;
                bool rounded = dx < 0.5f && dy < 0.5f;
                const vec4& px = f.rgba[std::size_t{y} * p.width + x];
                INFO("pixel " << x << "," << y << " at " << wx << "," << wy);
                if (edge < -1e-3f) CHECK(px.w == 0.0f);
                if (edge > 1e-3f && !rounded) CHECK(px.w == 1.0f);
                if (edge > 1.0f) CHECK(px.x == Approx(1.0f).epsilon(1e-5));
                checked += std::fabs(edge) > 1e-3f ? 1u : 0u;
            }
        }
        CHECK(checked > 3000);
        // Semi-transparent: a ray through the box hits it twice, entering (the shell before the
        // grid) and leaving (the shell after it); from inside the box, once.
        p.isos = {{0.5f, vec4(1.0f, 1.0f, 1.0f, 0.5f)}};
        std::vector<std::uint32_t> params = iso_params(p, s.words.size(), s.gw.words.size());
        shared::Words pw{params.data(), params.size()}, tw{s.words.data(), s.words.size()},
            gw{s.gw.words.data(), s.gw.words.size()};
        shared::SylvaIsoParams sp = shared::sylva_iso_read_params(pw);
        shared::SylvaIkdHeader hdr = shared::sylva_iso_read_header(tw, sp);
        vec3 across = glm::normalize(vec3(1.0f, 0.2f, 0.3f));  // leaves through the x = top.x face
        for (std::uint32_t walker : {SYLVA_ISO_WALK_TREE, SYLVA_ISO_WALK_DDA}) {
            sp.walker = walker;
            CHECK(shared::sylva_iso_trace(tw, gw, sp, hdr, vec3(-2.0f, 1.1f, 3.3f), across).hits == 2);
            CHECK(shared::sylva_iso_trace(tw, gw, sp, hdr, vec3(4.5f, 1.1f, 3.3f), across).hits == 1);
            CHECK(shared::sylva_iso_trace(tw, gw, sp, hdr, vec3(-2.0f, -1.0f, 3.3f), vec3(1.0f, 0.0f, 0.0f)).hits == 0);
        }
    }
}

TEST_CASE("iso rendering: with a constant border the tree, the DDA, packets and native grids agree bit for bit",
          "[ikd][iso][border][packet][native]") {
    ThreadPool pool(2);
    volume::DensityGrid field = volume::marschner_lobb({33, 20, 27});  // surfaces cross every face
    volume::Volume v8 = test::quantised(field, volume::ScalarType::U8, 0.0f, 255.0f);
    volume::DensityGrid g = volume::normalize(v8);
    Scene s(g);
    GridWords native = GridWords::native(v8);
    for (float border : {0.0f, 0.45f, 1.0f}) {
        INFO("border " << border);
        IsoRenderParams p = params_for(s, {{0.3f, vec4(0.2f, 0.6f, 0.9f, 0.35f)}, {0.6f, vec4(0.9f, 0.4f, 0.2f, 0.5f)}});
        IsoCounters open, n;
        render_iso_cpu(s.words, s.gw, p, pool, &open);
        p.border = border;
        Frame want = render_iso_cpu(s.words, s.gw, p, pool, &n);
        CHECK(n.hits > open.hits + 200);  // the faces' surfaces
        CHECK(n.errors == 0);
        p.walker = IsoWalker::Dda;
        IsoCounters nd;
        CHECK(bits_of(render_iso_cpu(s.words, s.gw, p, pool, &nd)) == bits_of(want));
        CHECK(nd.cells == n.cells);
        CHECK(nd.hits == n.hits);
        CHECK(bits_of(render_iso_cpu(s.words, native, p, pool)) == bits_of(want));
        p.walker = IsoWalker::Tree;
        for (PacketLanes lanes : {PacketLanes::Four, PacketLanes::Eight, PacketLanes::Sixteen}) {
            IsoCounters np;
            CHECK(bits_of(render_iso_cpu_packets(s.words, s.gw, p, pool, &np, lanes)) == bits_of(want));
            CHECK(np.cells == n.cells);
            CHECK(np.hits == n.hits);
            CHECK(bits_of(render_iso_cpu_packets(s.words, native, p, pool, nullptr, lanes)) == bits_of(want));
        }
    }
}

TEST_CASE("iso rendering: a constant border gives the image of the grid padded with the border's samples",
          "[ikd][iso][border]") {
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        float border;
    };
    volume::DensityGrid stretched = volume::marschner_lobb({25, 25, 25});
    stretched.spacing = vec3(0.7f, 1.3f, 0.45f);
    for (Case c : {Case{volume::marschner_lobb({33, 20, 27}), 0.0f},
                   Case{volume::radial_falloff({19, 7, 33}, vec3(9.5f, 3.0f, 16.5f), 15.0f, vec3(1.0f, 2.0f, 0.5f)), 0.0f},
                   Case{volume::marschner_lobb({25, 25, 25}), 0.7f}, Case{stretched, 0.2f}}) {
        INFO("dims " << c.grid.dims.x << "x" << c.grid.dims.y << "x" << c.grid.dims.z << " border " << c.border);
        Scene s(c.grid);
        // The reference: the padded grid's cells, no border, its sample (0, 0, 0) one spacing lower.
        volume::DensityGrid big = padded(c.grid, c.border);
        ikd::Tree t = ikd::build(big);
        t.origin = -0.5f * big.spacing;
        std::vector<std::uint32_t> ref_words = ikd::encode(t);
        GridWords ref_grid = GridWords::from(big);
        IsoRenderParams p = params_for(s, {{0.3f, vec4(0.2f, 0.6f, 0.9f, 0.35f)}, {0.6f, vec4(0.9f, 0.4f, 0.2f, 0.5f)},
                                           {0.9f, vec4(1.0f)}}, 128, 96);
        IsoCounters nr, nb;
        Frame ref = render_iso_cpu(ref_words, ref_grid, p, pool, &nr);
        p.border = c.border;
        Frame got = render_iso_cpu(s.words, s.gw, p, pool, &nb);
        // Equal but for rounding: the two map a ray into cell spaces one cell apart.
        std::size_t differ = 0;
        float worst = 0.0f;
        for (std::size_t i = 0; i < ref.rgba.size(); ++i) {
            float d = 0.0f;
            for (int k = 0; k < 4; ++k) d = std::max(d, std::fabs(ref.rgba[i][k] - got.rgba[i][k]));
            worst = std::max(worst, d);
            differ += d > 1e-4f ? 1u : 0u;
        }
        INFO("hits " << nb.hits << " (padded " << nr.hits << "), pixels off by > 1e-4: " << differ << ", worst " << worst);
        CHECK(nr.hits > 2000);
        if (c.grid.spacing == vec3(1.0f)) {
            // Unit cells: the two cell spaces differ by exactly 1 in float, so the same bits.
            CHECK(bits_of(got) == bits_of(ref));
            CHECK(nb.hits == nr.hits);
        }
        CHECK(differ <= ref.rgba.size() / 500);
        CHECK(std::abs(static_cast<long>(nb.hits) - static_cast<long>(nr.hits)) <= static_cast<long>(nr.hits / 500));
    }
}

TEST_CASE("iso rendering: a border value that is not finite is refused; a corrupted tree with a border draws nothing",
          "[ikd][iso][border][errors]") {
    ThreadPool pool(2);
    Scene s(volume::marschner_lobb({21, 21, 21}));
    IsoRenderParams p = params_for(s, {{0.5f, vec4(1.0f)}}, 32, 24);
    p.border = std::nanf("");
    CHECK_THROWS_WITH(render_iso_cpu(s.words, s.gw, p, pool), Contains("border value is not finite"));
    p.border = std::numeric_limits<float>::infinity();
    CHECK_THROWS_WITH(render_iso_cpu_packets(s.words, s.gw, p, pool), Contains("border value is not finite"));
    p.border = 0.0f;
    std::vector<std::uint32_t> bad = s.words;
    bad[0] = 0;
    IsoCounters n;
    Frame f = render_iso_cpu(bad, s.gw, p, pool, &n);
    CHECK(n.errors == std::uint64_t{32} * 24);
    CHECK(n.hits == 0);
    for (const vec4& c : f.rgba) CHECK(c.w == 0.0f);
}

TEST_CASE("iso rendering: a constant border walks only the faces whose densities reach an isovalue", "[ikd][iso][border]") {
    ThreadPool pool(2);
    // A ramp along x: face -x reads 0, face +x reads 1, the four others 0 .. 1.
    const std::uint32_t n = 17;
    volume::DensityGrid ramp{{n, 9, 6}, vec3(0.5f, 1.0f, 1.0f), std::vector<float>(n * 9 * 6)};
    for (std::uint32_t z = 0; z < 6; ++z)
        for (std::uint32_t y = 0; y < 9; ++y)
            for (std::uint32_t x = 0; x < n; ++x) ramp.values[volume::voxel_index(ramp.dims, x, y, z)] = float(x) / float(n - 1);
    Scene s(ramp);
    IsoFaceRanges r = iso_face_ranges(s.words, s.gw);
    CHECK(r.lo[0] == 0.0f);
    CHECK(r.hi[0] == 0.0f);
    CHECK(r.lo[1] == 1.0f);
    CHECK(r.hi[1] == 1.0f);
    for (int f = 2; f < 6; ++f) {
        CHECK(r.lo[f] == 0.0f);
        CHECK(r.hi[f] == 1.0f);
    }
    IsoRenderParams p = params_for(s, {{0.3f, vec4(1.0f, 1.0f, 1.0f, 0.5f)}}, 64, 48);
    p.border = 0.0f;
    CHECK(iso_border_faces(r, p) == 0x3Eu);  // all but -x: 0 there and outside
    p.border = 1.0f;
    CHECK(iso_border_faces(r, p) == 0x3Du);  // all but +x
    p.isos = {{0.3f, vec4(1.0f)}, {1.0f, vec4(1.0f)}};
    CHECK(iso_border_faces(r, p) == 0x3Fu);  // 1.0 lies in +x's [1, 1]
    p.border.reset();
    CHECK(iso_border_faces(r, p) == 0u);
    // Skipping the faces' cells changes no pixel; a grid whose faces cannot reach the isovalue
    // walks no shell at all: the border's image and steps are those without a border.
    for (float border : {0.0f, 1.0f}) {
        p.isos = {{0.3f, vec4(1.0f, 1.0f, 1.0f, 0.5f)}};
        p.border = border;
        std::uint32_t faces = iso_border_faces(iso_face_ranges(s.words, s.gw), p);
        std::vector<std::uint32_t> all = iso_params(p, s.words.size(), s.gw.words.size()),
                                   some = iso_params(p, s.words.size(), s.gw.words.size(), {}, faces);
        shared::Words tw{s.words.data(), s.words.size()}, gw{s.gw.words.data(), s.gw.words.size()};
        shared::SylvaIsoParams sa = shared::sylva_iso_read_params(shared::Words{all.data(), all.size()});
        shared::SylvaIsoParams ss = shared::sylva_iso_read_params(shared::Words{some.data(), some.size()});
        shared::SylvaIkdHeader hdr = shared::sylva_iso_read_header(tw, sa);
        std::uint64_t steps_all = 0, steps_some = 0, hits = 0;
        for (std::uint32_t y = 0; y < p.height; ++y)
            for (std::uint32_t x = 0; x < p.width; ++x) {
                shared::SylvaIsoRay a = shared::sylva_iso_pixel(tw, gw, sa, hdr, x, y);
                shared::SylvaIsoRay b = shared::sylva_iso_pixel(tw, gw, ss, hdr, x, y);
                CHECK(std::bit_cast<std::uint32_t>(a.rgba.x) == std::bit_cast<std::uint32_t>(b.rgba.x));
                CHECK(std::bit_cast<std::uint32_t>(a.rgba.w) == std::bit_cast<std::uint32_t>(b.rgba.w));
                CHECK(a.hits == b.hits);
                steps_all += a.steps;
                steps_some += b.steps;
                hits += a.hits;
            }
        CHECK(hits > 500);
        CHECK(steps_some < steps_all);  // the walk leaves the faces out
    }
    volume::DensityGrid ball = volume::radial_falloff({24, 20, 28}, vec3(12.0f, 10.0f, 14.0f), 10.0f, vec3(1.0f));
    Scene b(ball);
    p = params_for(b, {{0.3f, vec4(0.9f)}});
    IsoCounters open, closed;
    Frame want = render_iso_cpu(b.words, b.gw, p, pool, &open);
    p.border = 0.0f;
    CHECK(iso_border_faces(iso_face_ranges(b.words, b.gw), p) == 0u);
    Frame got = render_iso_cpu_packets(b.words, b.gw, p, pool, &closed);
    IsoCounters single;
    CHECK(bits_of(render_iso_cpu(b.words, b.gw, p, pool, &single)) == bits_of(want));
    CHECK(bits_of(got) == bits_of(want));
    CHECK(single.steps == open.steps);
    CHECK(open.hits > 500);
}
