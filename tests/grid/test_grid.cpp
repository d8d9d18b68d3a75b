// Native-type grids (uint8 / uint16 words normalised on the fly), border modes of the grid
// samplers, the exact normalisation v / max and threshold_to_zero (issue 17). References are
// independent: float division written out in the test, a plain float trilinear sampler over a
// grid padded with the border value, and the float32 copy of the same data.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <set>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/read_raw.hpp>

#include "../missing_data.hpp"

using namespace sylva;

namespace {

volume::Volume random_volume(volume::ScalarType type, volume::Dims dims, std::uint32_t seed, float empty = 0.6f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::Volume v;
    v.type = type;
    v.dims = dims;
    std::size_t n = volume::voxel_count(dims), b = volume::scalar_bytes(type);
    v.bytes.resize(n * b);
    for (std::size_t i = 0; i < n; ++i) {
        float x = u(rng) < empty ? 0.0f : u(rng);
        if (type == volume::ScalarType::U8) {
            v.bytes[i] = std::byte(static_cast<std::uint8_t>(x * 255.0f));
        } else if (type == volume::ScalarType::U16) {
            auto s = static_cast<std::uint16_t>(x * 65535.0f);
            std::memcpy(&v.bytes[2 * i], &s, 2);
        } else {
            std::memcpy(&v.bytes[4 * i], &x, 4);
        }
    }
    v.range_lo = 0.0f;
    v.range_hi = type == volume::ScalarType::U8 ? 255.0f : (type == volume::ScalarType::U16 ? 65535.0f : 1.0f);
    return v;
}

/// Independent trilinear reference: the grid padded with one voxel of `outside` on every side
/// (or the edge voxel, when clamping), sampled at voxel-space point u in double precision.
double reference_sample(const volume::DensityGrid& g, const GridBorder& b, glm::dvec3 u) {
    auto at = [&](std::int64_t x, std::int64_t y, std::int64_t z) -> double {
        bool inside = x >= 0 && y >= 0 && z >= 0 && x < g.dims.x && y < g.dims.y && z < g.dims.z;
        if (!inside && b.mode == BorderMode::Constant) return b.value;
        return g.clamped(x, y, z);
    };
    glm::dvec3 c = u;
    if (b.mode == BorderMode::Clamp) c = glm::clamp(u, glm::dvec3(0.0), glm::dvec3(g.dims) - 1.0);
    glm::dvec3 f0 = glm::floor(c), f = c - f0;
    auto x0 = std::int64_t(f0.x), y0 = std::int64_t(f0.y), z0 = std::int64_t(f0.z);
    double r = 0.0;
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx)
                r += (dx ? f.x : 1.0 - f.x) * (dy ? f.y : 1.0 - f.y) * (dz ? f.z : 1.0 - f.z) * at(x0 + dx, y0 + dy, z0 + dz);
    return r;
}

std::size_t differing(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) n += std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0;
    return n;
}

double alpha_sum(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.a;
    return s;
}

std::vector<std::uint32_t> ramp_tf(float lo) {
    std::vector<std::uint32_t> tf(256);
    for (std::uint32_t i = 0; i < 256; ++i) {
        float d = float(i) / 255.0f;
        std::uint32_t a = d > lo ? static_cast<std::uint32_t>(std::lround((d - lo) / (1.0f - lo) * 120.0f)) : 0u;
        tf[i] = i | ((255u - i) << 8) | (128u << 16) | (a << 24);
    }
    return tf;
}

VolumeRenderParams params_for(const Aabb& box, vec3 from, std::uint32_t size, std::vector<std::uint32_t> tf) {
    VolumeRenderParams p;
    p.width = p.height = size;
    p.camera = Camera::framing(box, from, 34.0f).frame(size, size);
    p.tf = std::move(tf);
    return p;
}

/// A volume whose 8^3 bricks are of three kinds: zero outside a ball, a block of one value
/// (uniform bricks that are not zero), random inside the ball. `dims` not multiples of 8 give
/// partial bricks on the far faces.
volume::Volume bricky_volume(volume::ScalarType type, volume::Dims dims, std::uint32_t seed) {
    volume::Volume v = random_volume(type, dims, seed, 0.3f);
    const std::size_t b = volume::scalar_bytes(type);
    vec3 c = vec3(dims) * 0.45f;
    float r = float(std::min({dims.x, dims.y, dims.z})) * 0.3f;
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) {
                std::size_t i = x + std::size_t{dims.x} * (y + std::size_t{dims.y} * z);
                bool block = x >= dims.x - 9 && y < 16 && z < 16;  // a uniform 200 (or 50000) slab
                if (block) {
                    if (b == 1) v.bytes[i] = std::byte(200);
                    else {
                        std::uint16_t s = 50000;
                        std::memcpy(&v.bytes[2 * i], &s, 2);
                    }
                } else if (glm::length(vec3(x, y, z) - c) > r) {
                    std::memset(&v.bytes[b * i], 0, b);
                }
            }
    return v;
}

/// Independent count of the 8^3 bricks whose voxels inside the grid are not all one value.
std::size_t varied_bricks(const volume::Volume& v) {
    std::size_t n = 0;
    for (std::uint32_t bz = 0; bz < v.dims.z; bz += 8)
        for (std::uint32_t by = 0; by < v.dims.y; by += 8)
            for (std::uint32_t bx = 0; bx < v.dims.x; bx += 8) {
                std::set<float> values;
                for (std::uint32_t z = bz; z < std::min(bz + 8, v.dims.z); ++z)
                    for (std::uint32_t y = by; y < std::min(by + 8, v.dims.y); ++y)
                        for (std::uint32_t x = bx; x < std::min(bx + 8, v.dims.x); ++x)
                            values.insert(v.value(x + std::size_t{v.dims.x} * (y + std::size_t{v.dims.y} * z)));
                n += values.size() > 1;
            }
    return n;
}

}  // namespace

TEST_CASE("normalize is exactly v / max; threshold_to_zero cuts below the threshold", "[grid]") {
    volume::Volume v;
    v.type = volume::ScalarType::U8;
    v.dims = {256, 1, 1};
    v.bytes.resize(256);
    for (std::size_t i = 0; i < 256; ++i) v.bytes[i] = std::byte(i);
    v.range_lo = 0.0f;
    v.range_hi = 255.0f;
    volume::DensityGrid g = volume::normalize(v);
    std::size_t off_by_mult = 0;
    for (std::uint32_t i = 0; i < 256; ++i) {
        float want = float(i) / 255.0f;  // the correctly rounded quotient
        REQUIRE(g.values[i] == want);
        off_by_mult += float(i) * (1.0f / 255.0f) != want;
    }
    CHECK(off_by_mult > 100);  // the old normalisation (a product with 1/255) differed here
    // uint16 over a sub-range: clamped, divided as written.
    volume::Volume w = random_volume(volume::ScalarType::U16, {37, 5, 3}, 4);
    w.range_lo = 1000.0f;
    w.range_hi = 50000.0f;
    volume::DensityGrid gw = volume::normalize(w);
    for (std::size_t i = 0; i < gw.values.size(); ++i)
        REQUIRE(gw.values[i] == std::clamp((w.value(i) - 1000.0f) / 49000.0f, 0.0f, 1.0f));

    volume::DensityGrid t = g;
    std::size_t cut = volume::threshold_to_zero(t, 0.1f);
    std::size_t expect = 0;
    for (std::uint32_t i = 0; i < 256; ++i) {
        bool below = g.values[i] < 0.1f;
        expect += below && g.values[i] != 0.0f;
        REQUIRE(t.values[i] == (below ? 0.0f : g.values[i]));
    }
    CHECK(cut == expect);
    CHECK(cut == 25);  // 1 .. 25 (25 / 255 < 0.1 <= 26 / 255)
    volume::Volume raw = v;
    CHECK(volume::threshold_to_zero(raw, 26.0f) == 25);
    for (std::uint32_t i = 0; i < 256; ++i) REQUIRE(std::to_integer<std::uint32_t>(raw.bytes[i]) == (i < 26 ? 0u : i));
    CHECK_THROWS_WITH(volume::threshold_to_zero(t, NAN), Catch::Contains("threshold is not finite"));
    raw.bytes.pop_back();
    CHECK_THROWS_WITH(volume::threshold_to_zero(raw, 3.0f), Catch::Contains("bytes do not match"));
}

TEST_CASE("native grids: uint8 and uint16 words read the float copy's densities bit for bit", "[grid]") {
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16, volume::ScalarType::F32}) {
        INFO(volume::scalar_name(type));
        volume::Volume v = random_volume(type, {13, 7, 5}, 11);  // 455 voxels: a padded last word
        if (type == volume::ScalarType::U16) {
            v.range_lo = 300.0f;
            v.range_hi = 60000.0f;
        }
        GridWords native = GridWords::native(v);
        volume::DensityGrid copy = volume::normalize(v);
        std::size_t n = copy.values.size();
        CHECK(native.grid_bytes() == n * volume::scalar_bytes(type));
        CHECK(native.words.size() == (n * volume::scalar_bytes(type) + 3) / 4);
        for (std::size_t i = 0; i < n; ++i) REQUIRE(native.density(i) == copy.values[i]);
        GridWords f = GridWords::from(copy);
        std::mt19937 rng(3);
        std::uniform_real_distribution<float> px(-1.5f, 14.5f), py(-1.5f, 8.5f), pz(-1.5f, 6.5f);
        for (GridBorder b : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(0.7f)}) {
            native.sampling.border = b;
            f.sampling.border = b;
            shared::Words nw{native.words.data(), native.words.size()}, fw{f.words.data(), f.words.size()};
            for (int k = 0; k < 2000; ++k) {
                vec3 p(px(rng), py(rng), pz(rng));
                REQUIRE(shared::sylva_grid_sample(nw, native.desc(), p) == shared::sylva_grid_sample(fw, f.desc(), p));
                vec3 gn = shared::sylva_grid_sample_gradient(nw, native.desc(), p);
                vec3 gf = shared::sylva_grid_sample_gradient(fw, f.desc(), p);
                REQUIRE(gn == gf);
            }
        }
    }
}

TEST_CASE("border modes: samples equal a float trilinear reference over a padded grid", "[grid]") {
    volume::Volume v = random_volume(volume::ScalarType::U8, {6, 5, 4}, 21, 0.2f);
    volume::DensityGrid g = volume::normalize(v);
    std::mt19937 rng(8);
    // Points on a 1/16-voxel lattice in and around the grid (exact voxel-space coordinates).
    std::uniform_int_distribution<int> qx(-40, 6 * 16 + 40), qy(-40, 5 * 16 + 40), qz(-40, 4 * 16 + 40);
    for (GridBorder b : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(0.5f), GridBorder::constant(1.0f)}) {
        INFO("border " << int(b.mode) << " value " << b.value);
        GridWords w = GridWords::native(v, b);
        shared::Words ww{w.words.data(), w.words.size()};
        std::size_t edge_points = 0;
        for (int k = 0; k < 5000; ++k) {
            vec3 p(float(qx(rng)) / 16.0f, float(qy(rng)) / 16.0f, float(qz(rng)) / 16.0f);
            glm::dvec3 u = glm::dvec3(p) - 0.5;
            double want = reference_sample(g, b, u);
            float got = shared::sylva_grid_sample(ww, w.desc(), p);
            INFO("p " << p.x << "," << p.y << "," << p.z);
            REQUIRE(std::abs(double(got) - want) <= 1e-6);
            edge_points += glm::any(glm::lessThan(u, glm::dvec3(0.0))) ||
                           glm::any(glm::greaterThan(u, glm::dvec3(g.dims) - 1.0));
        }
        CHECK(edge_points > 1000);
    }
    // Corner of the grid (world 0, 0, 0): a quarter... an eighth of the corner voxel, the rest border.
    GridWords w = GridWords::native(v, GridBorder::constant(0.25f));
    shared::Words ww{w.words.data(), w.words.size()};
    double v0 = g.values[0];
    CHECK(shared::sylva_grid_sample(ww, w.desc(), vec3(0.0f)) == Approx(v0 / 8.0 + 0.25 * 7.0 / 8.0).margin(1e-7));
    // Far outside: the border value itself.
    CHECK(shared::sylva_grid_sample(ww, w.desc(), vec3(-50.0f, 3.0f, 2.0f)) == 0.25f);
}

TEST_CASE("native grids: marcher and kd DVR over uint8 / uint16 words equal the float32 copy", "[grid]") {
    ThreadPool pool(2);
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        INFO(volume::scalar_name(type));
        volume::Volume v = random_volume(type, {30, 26, 22}, 5, 0.93f);
        for (GridBorder b : {GridBorder{}, GridBorder::clamp()}) {
            GridWords native = GridWords::native(v, b);
            volume::DensityGrid copy = volume::normalize(v);
            GridWords f = GridWords::from(copy, b);
            for (bool shading : {false, true}) {
                VolumeRenderParams p = params_for(copy.world_box(), vec3(0.4f, 0.3f, 1.0f), 40, ramp_tf(0.05f));
                p.shading = shading;
                Frame a = render_dvr_cpu(native, p, pool), c = render_dvr_cpu(f, p, pool);
                CHECK(alpha_sum(a) > 20.0);
                CHECK(differing(a, c) == 0);
                EssRebuilder<ThreadPool> ess(native, kdtree::Config::deep(), pool);
                std::vector<std::uint32_t> kd = kdtree::encode(ess.rebuild(p.tf));
                EssRebuilder<ThreadPool> ess_f(copy, kdtree::Config::deep(), pool, b);
                CHECK(kd == kdtree::encode(ess_f.rebuild(p.tf)));  // same codes from the words
                Frame k = render_kd_dvr_cpu(native, kd, p, pool);
                CHECK(differing(k, c) == 0);
            }
        }
    }
}

TEST_CASE("native grids: bad words, ranges and borders are refused", "[grid]") {
    volume::Volume v = random_volume(volume::ScalarType::U8, {8, 8, 8}, 2);
    GridWords w = GridWords::native(v);
    VolumeRenderParams p = params_for(w.world_box(), vec3(0.0f, 0.0f, 1.0f), 8, ramp_tf(0.1f));
    CHECK_NOTHROW(dvr_params(w, p));
    std::vector<std::uint32_t> params = dvr_params(w, p);
    CHECK(params[38] == SYLVA_BORDER_CONSTANT);
    CHECK(params[40] == SYLVA_GRID_U8);
    CHECK(std::bit_cast<float>(params[42]) == 255.0f);
    GridWords shorter = w;
    shorter.words.pop_back();
    CHECK_THROWS_WITH(dvr_params(shorter, p), Catch::Contains("words for its dimensions"));
    GridWords nan_border = w;
    nan_border.sampling.border.value = NAN;
    CHECK_THROWS_WITH(dvr_params(nan_border, p), Catch::Contains("border value is not finite"));
    volume::Volume flat = v;
    flat.range_hi = flat.range_lo;
    CHECK_THROWS_WITH(GridWords::native(flat), Catch::Contains("hi > lo"));
    volume::Volume cut = v;
    cut.bytes.pop_back();
    CHECK_THROWS_WITH(GridWords::native(cut), Catch::Contains("bytes do not match"));
}

TEST_CASE("native grids: the uint8 aneurism renders as its float32 copy (marcher and kd DVR)", "[grid][data]") {
    std::filesystem::path path = testdata::require("aneurism_256x256x256_uint8.raw");
    volume::Volume v = volume::read_raw(path, volume::parse_raw_name(path.filename().string()));
    v.range_lo = 0.0f;
    v.range_hi = 255.0f;
    ThreadPool pool(2);
    GridWords native = GridWords::native(v);
    CHECK(native.grid_bytes() == volume::voxel_count(v.dims));  // one byte a voxel
    CHECK(native.words.size() * 4 == volume::voxel_count(v.dims));
    volume::DensityGrid copy = volume::normalize(v);
    GridWords f = GridWords::from(copy);
    VolumeRenderParams p = params_for(copy.world_box(), vec3(0.3f, 0.5f, 1.0f), 64, ramp_tf(0.1f));
    Frame a = render_dvr_cpu(native, p, pool), c = render_dvr_cpu(f, p, pool);
    CHECK(alpha_sum(a) > 50.0);
    CHECK(differing(a, c) == 0);
    EssRebuilder<ThreadPool> ess(native, kdtree::Config::deep(), pool);
    Frame k = render_kd_dvr_cpu(native, kdtree::encode(ess.rebuild(p.tf)), p, pool);
    CHECK(differing(k, c) == 0);
}

TEST_CASE("sparse grids: every voxel, sample and gradient equals the dense native grid", "[grid]") {
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        for (volume::Dims dims : {volume::Dims{29, 17, 11}, volume::Dims{32, 24, 16}, volume::Dims{3, 2, 9}}) {
            INFO(volume::scalar_name(type) << " " << dims.x << "x" << dims.y << "x" << dims.z);
            volume::Volume v = bricky_volume(type, dims, 31);
            if (type == volume::ScalarType::U16) {
                v.range_lo = 300.0f;
                v.range_hi = 60000.0f;
            }
            GridWords dense = GridWords::native(v), sparse = GridWords::sparse(v);
            CHECK(sparse.sampling.format == (type == volume::ScalarType::U8 ? GridFormat::SparseU8 : GridFormat::SparseU16));
            std::size_t table = sparse_table_words(dims), stored = varied_bricks(v);
            CHECK(table == std::size_t((dims.x + 7) / 8) * ((dims.y + 7) / 8) * ((dims.z + 7) / 8));
            CHECK(sparse.words.size() == table + stored * (type == volume::ScalarType::U8 ? 128u : 256u));
            CHECK(sparse.grid_bytes() == sparse.words.size() * 4);
            if (dims.x >= 29) CHECK(stored < table);  // zero and uniform bricks are not stored
            CHECK_NOTHROW(sparse.check_words("test"));
            for (std::size_t i = 0; i < sparse.voxels(); ++i) REQUIRE(sparse.density(i) == dense.density(i));
            std::mt19937 rng(3);
            std::uniform_real_distribution<float> px(-1.5f, float(dims.x) + 1.5f), py(-1.5f, float(dims.y) + 1.5f),
                pz(-1.5f, float(dims.z) + 1.5f);
            for (GridBorder b : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(0.7f)}) {
                dense.sampling.border = b;
                sparse.sampling.border = b;
                shared::Words dw{dense.words.data(), dense.words.size()}, sw{sparse.words.data(), sparse.words.size()};
                for (int k = 0; k < 3000; ++k) {
                    vec3 p(px(rng), py(rng), pz(rng));
                    REQUIRE(shared::sylva_grid_sample(sw, sparse.desc(), p) == shared::sylva_grid_sample(dw, dense.desc(), p));
                    REQUIRE(shared::sylva_grid_sample_gradient(sw, sparse.desc(), p) ==
                            shared::sylva_grid_sample_gradient(dw, dense.desc(), p));
                }
            }
        }
    }
}

TEST_CASE("sparse grids: marcher and kd DVR equal the dense native grid's images", "[grid]") {
    ThreadPool pool(2);
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        INFO(volume::scalar_name(type));
        volume::Volume v = bricky_volume(type, {37, 30, 26}, 5);
        for (GridBorder b : {GridBorder{}, GridBorder::clamp()}) {
            GridWords dense = GridWords::native(v, b), sparse = GridWords::sparse(v, b);
            CHECK(sparse.grid_bytes() < dense.grid_bytes());
            for (bool shading : {false, true}) {
                VolumeRenderParams p = params_for(dense.world_box(), vec3(0.4f, 0.3f, 1.0f), 40, ramp_tf(0.05f));
                p.shading = shading;
                Frame a = render_dvr_cpu(sparse, p, pool), c = render_dvr_cpu(dense, p, pool);
                CHECK(alpha_sum(a) > 20.0);
                CHECK(differing(a, c) == 0);
                EssRebuilder<ThreadPool> ess(sparse, kdtree::Config::deep(), pool), ess_d(dense, kdtree::Config::deep(), pool);
                std::vector<std::uint32_t> kd = kdtree::encode(ess.rebuild(p.tf));
                CHECK(kd == kdtree::encode(ess_d.rebuild(p.tf)));  // same codes from either layout
                CHECK(differing(render_kd_dvr_cpu(sparse, kd, p, pool), c) == 0);
            }
        }
    }
}

TEST_CASE("sparse grids: corrupt or truncated brick tables and float volumes are refused", "[grid]") {
    volume::Volume v = bricky_volume(volume::ScalarType::U8, {24, 16, 16}, 9);
    GridWords w = GridWords::sparse(v);
    VolumeRenderParams p = params_for(w.world_box(), vec3(0.0f, 0.0f, 1.0f), 8, ramp_tf(0.1f));
    CHECK(dvr_params(w, p)[40] == SYLVA_GRID_SPARSE_U8);
    std::size_t table = sparse_table_words(v.dims);
    REQUIRE(table == 12);
    std::size_t stored_at = table;
    for (std::size_t b = 0; b < table; ++b)
        if ((w.words[b] & SYLVA_GRID_UNIFORM_BIT) == 0u) stored_at = b;
    REQUIRE(stored_at < table);
    auto bad = [&](auto edit, const char* what) {
        GridWords c = w;
        edit(c.words);
        INFO(what);
        CHECK_THROWS_WITH(dvr_params(c, p), Catch::Contains(what));
        CHECK_THROWS_WITH(c.check_words("x"), Catch::Contains(what));
        ThreadPool pool(1);
        CHECK_THROWS_WITH(EssRebuilder<ThreadPool>(c, kdtree::Config::deep(), pool), Catch::Contains(what));
        // The sampler itself never reads outside the words, whatever the table says.
        shared::Words cw{c.words.data(), c.words.size()};
        for (float x = -1.0f; x < 25.0f; x += 0.37f) {
            float d = shared::sylva_grid_sample(cw, c.desc(), vec3(x, 0.3f * x, 0.6f * x));
            REQUIRE((d >= 0.0f && d <= 1.0f));
        }
    };
    bad([&](std::vector<std::uint32_t>& ws) { ws[stored_at] = 3; }, "outside the brick area");
    bad([&](std::vector<std::uint32_t>& ws) { ws[stored_at] = std::uint32_t(ws.size()) - 100; }, "outside the brick area");
    bad([&](std::vector<std::uint32_t>& ws) { ws[stored_at] = 0x7FFFFFF0u; }, "outside the brick area");
    bad([&](std::vector<std::uint32_t>& ws) { ws[0] = SYLVA_GRID_UNIFORM_BIT | 300u; }, "beyond the format's 255");
    bad([&](std::vector<std::uint32_t>& ws) { ws[0] = SYLVA_GRID_UNIFORM_BIT | (1u << 20); }, "beyond the format's 255");
    bad([&](std::vector<std::uint32_t>& ws) { ws.resize(5); }, "hold no brick table of 12 entries");
    bad([&](std::vector<std::uint32_t>& ws) { ws.pop_back(); }, "outside the brick area");
    volume::Volume f = random_volume(volume::ScalarType::F32, {4, 4, 4}, 1);
    CHECK_THROWS_WITH(GridWords::sparse(f), Catch::Contains("not float32"));
    volume::Volume cut = v;
    cut.bytes.pop_back();
    CHECK_THROWS_WITH(GridWords::sparse(cut), Catch::Contains("bytes do not match"));
    // The implicit kd-tree reads dense grids: a sparse grid is named, not misread (a native one
    // is read: tests/ikd/test_iso_render.cpp).
    IsoRenderParams ip;
    ip.width = ip.height = 4;
    ip.camera = p.camera;
    ThreadPool pool1(1);
    CHECK_THROWS_WITH(render_iso_cpu(std::span<const std::uint32_t>{}, w, ip, pool1),
                      Catch::Contains("reads dense grids") && Catch::Contains("not the sparse format 3"));
    GridWords unknown = w;
    unknown.sampling.format = static_cast<GridFormat>(5u);
    CHECK_THROWS_WITH(dvr_params(unknown, p), Catch::Contains("unknown voxel format 5"));
}

TEST_CASE("sparse grids: the uint8 aneurism in 8^3 bricks renders as the dense grid in under 10.9 MB", "[grid][data]") {
    std::filesystem::path path = testdata::require("aneurism_256x256x256_uint8.raw");
    volume::Volume v = volume::read_raw(path, volume::parse_raw_name(path.filename().string()));
    v.range_lo = 0.0f;
    v.range_hi = 255.0f;
    ThreadPool pool(2);
    GridWords dense = GridWords::native(v), sparse = GridWords::sparse(v);
    std::size_t stored = (sparse.words.size() - sparse_table_words(v.dims)) / 128;
    INFO("sparse grid " << sparse.grid_bytes() << " bytes, " << stored << " of " << sparse_table_words(v.dims)
                        << " bricks stored");
    CHECK(stored == varied_bricks(v));
    CHECK(sparse.grid_bytes() < 10'900'000u);  // NanoVDB's float grid of the dilated active set (issue 17)
    VolumeRenderParams p = params_for(dense.world_box(), vec3(0.3f, 0.5f, 1.0f), 64, ramp_tf(0.1f));
    Frame a = render_dvr_cpu(sparse, p, pool), c = render_dvr_cpu(dense, p, pool);
    CHECK(alpha_sum(a) > 50.0);
    CHECK(differing(a, c) == 0);
    EssRebuilder<ThreadPool> ess(sparse, kdtree::Config::deep(), pool);
    CHECK(differing(render_kd_dvr_cpu(sparse, kdtree::encode(ess.rebuild(p.tf)), p, pool), c) == 0);
}
