// DVR with empty-space skipping by kd-trees (sylva/shared/kd_dvr.h, sylva/render/kd_volume.hpp)
// against the plain reference marcher (sylva_dvr_march), which knows nothing of trees: the
// images must be identical, bit for bit, on procedural and real volumes, for shallow and deep
// trees from the Vidal (full SVT) and binned builders. Also: the occupancy against brute-force
// neighbourhoods and an analytic TF test, every lattice sample taken exactly once where leaves
// share faces, and bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/query.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/volume/classify.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/transfer_function.hpp>

#include "reference.hpp"

using namespace sylva;

namespace {

enum class Builder { Vidal, Binned };

kdtree::Tree build_tree(const volume::Occupancy& occ, Builder b, const kdtree::Config& cfg, ThreadPool& pool) {
    return b == Builder::Vidal ? kdtree::build_vidal(occ, cfg) : kdtree::build_binned(occ, cfg, pool);
}

const char* name(Builder b) { return b == Builder::Vidal ? "vidal" : "binned"; }

/// The ESS occupancy of `g` under the TF words `tf` (segment codes, then the classifier).
volume::Occupancy occupancy_for(const volume::DensityGrid& g, const std::vector<std::uint32_t>& tf, ThreadPool& pool,
                                const GridBorder& border = {}) {
    return ess_occupancy(ess_codes(g, static_cast<std::uint32_t>(tf.size()), pool, border), ess_classifier(tf), pool);
}

/// Number of pixels whose RGBA differ in any bit.
std::size_t bitwise_differing(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) n += std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0;
    return n;
}

double summed_alpha(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.a;
    return s;
}

std::uint64_t summed_steps(const Frame& f) {
    std::uint64_t s = 0;
    for (std::uint32_t v : f.steps) s += v;
    return s;
}

std::uint32_t rgba8(float r, float g, float b, float a) {
    auto c = [](float x) { return static_cast<std::uint32_t>(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); };
    return c(r) | (c(g) << 8) | (c(b) << 16) | (c(a) << 24);
}

/// A 256-entry TF whose alpha is `peak` on [lo, hi] only (a band), colour varying with density.
std::vector<std::uint32_t> band_tf(float lo, float hi, float peak) {
    std::vector<std::uint32_t> tf(256);
    for (std::size_t i = 0; i < tf.size(); ++i) {
        float d = float(i) / 255.0f;
        tf[i] = rgba8(0.3f + 0.7f * d, 0.8f - 0.5f * d, 0.4f, d >= lo && d <= hi ? peak : 0.0f);
    }
    return tf;
}

/// Transfer functions for the block passes: a preset, a band, 1024 entries, all and nothing
/// visible, and combs.
std::vector<std::pair<std::string, std::vector<std::uint32_t>>> block_pass_tfs() {
    std::vector<std::pair<std::string, std::vector<std::uint32_t>>> tfs = {
        {"ct", volume::TransferFunction::ct_bone_tissue().packed_rgba8()},
        {"band", band_tf(0.3f, 0.36f, 0.4f)},
        {"ramp, 1024 entries", volume::TransferFunction::ramp(0.2f, 0.6f, vec4(1.0f, 0.8f, 0.5f, 0.6f), 1024).packed_rgba8()},
        {"all visible", std::vector<std::uint32_t>(256, rgba8(1.0f, 1.0f, 1.0f, 0.5f))},
        {"nothing visible", std::vector<std::uint32_t>(256, rgba8(1.0f, 1.0f, 1.0f, 0.0f))}};
    // A comb: 32 visible runs of buckets (more than the 8 the block pass tests as density
    // intervals, so its voxels go through their buckets), and 3 runs in a 100-entry TF.
    std::vector<std::uint32_t> comb(256), comb100(100);
    for (std::size_t i = 0; i < comb.size(); ++i) comb[i] = rgba8(1.0f, 1.0f, 1.0f, (i / 4) % 2 == 1 ? 0.5f : 0.0f);
    for (std::size_t i = 0; i < comb100.size(); ++i) comb100[i] = rgba8(1.0f, 1.0f, 1.0f, i % 30 == 7 ? 0.5f : 0.0f);
    tfs.emplace_back("comb of 32 runs", comb);
    tfs.emplace_back("100 entries, 3 runs", comb100);
    return tfs;
}

/// The grid borders of the block passes: zero, clamped, a constant inside the data's range.
std::vector<std::pair<std::string, GridBorder>> block_pass_borders() {
    return {{"zero", GridBorder{}}, {"clamp", GridBorder{BorderMode::Clamp, 0.0f}}, {"0.33", GridBorder{BorderMode::Constant, 0.33f}}};
}

VolumeRenderParams params(const volume::DensityGrid& g, vec3 from, std::uint32_t size,
                          std::vector<std::uint32_t> tf) {
    VolumeRenderParams p;
    p.width = p.height = size;
    p.camera = Camera::framing(g.world_box(), from, 34.0f).frame(size, size);
    p.tf = std::move(tf);
    p.unit = std::min({g.spacing.x, g.spacing.y, g.spacing.z});
    return p;
}

/// Renders `g` with the marcher and with ESS over a tree of every builder and depth and
/// requires identical images; returns the ESS/marcher ratio of summed steps (deep, Vidal).
double check_exact(const volume::DensityGrid& g, const VolumeRenderParams& p, ThreadPool& pool,
                   double min_alpha_sum, const GridBorder& border = {}) {
    GridWords gw = GridWords::from(g, border);
    volume::Occupancy occ = occupancy_for(g, p.tf, pool, border);
    Frame ref = render_dvr_cpu(gw, p, pool);
    INFO("occupied " << occ.count() << " of " << g.values.size() << " voxels");
    CHECK(summed_alpha(ref) > min_alpha_sum);  // the images are not trivially empty
    double ratio = 0.0;
    for (Builder b : {Builder::Vidal, Builder::Binned}) {
        for (bool deep : {false, true}) {
            kdtree::Tree t = build_tree(occ, b, deep ? kdtree::Config::deep() : kdtree::Config::shallow(), pool);
            std::vector<std::uint32_t> words = kdtree::encode(t);
            Frame ess = render_kd_dvr_cpu(gw, words, p, pool);
            ImageDifference d = compare_frames(ref, ess);
            INFO(name(b) << (deep ? " deep" : " shallow") << ": " << t.leaves.size() << " leaves, depth "
                         << t.stats.max_depth << ", PSNR " << d.psnr << " dB, max diff " << d.max_abs);
            CHECK(bitwise_differing(ref, ess) == 0);
            for (std::uint32_t s : ess.steps) REQUIRE(s != 0xFFFFFFFFu);
            if (deep && b == Builder::Vidal)
                ratio = double(summed_steps(ess)) / double(std::max<std::uint64_t>(summed_steps(ref), 1));
        }
    }
    return ratio;
}

}  // namespace

TEST_CASE("ess dvr: ESS images equal the marcher's on a sparse procedural volume", "[kd_dvr]") {
    ThreadPool pool(2);
    volume::SparseNbodyConfig cfg;
    cfg.blobs = 600;
    cfg.spacing = vec3(1.0f, 1.1f, 0.9f);
    volume::DensityGrid g = volume::sparse_nbody({64, 56, 48}, 3u, cfg);
    for (vec3 from : {vec3(0.4f, 0.3f, 1.0f), vec3(0.0f, 0.0f, 1.0f), vec3(1.0f, 0.0f, 0.0f), vec3(-0.3f, -0.9f, 0.2f)}) {
        INFO("view from " << from.x << "," << from.y << "," << from.z);
        VolumeRenderParams p = params(g, from, 64, volume::TransferFunction::ct_bone_tissue().packed_rgba8());
        p.shading = from.x > 0.3f;
        double ratio = check_exact(g, p, pool, 5.0);
        CHECK(ratio < 0.5);  // a sparse volume: most lattice samples are skipped
    }
}

TEST_CASE("ess dvr: ESS images equal the marcher's on Marschner-Lobb with a band TF", "[kd_dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = volume::marschner_lobb({40, 36, 44});
    for (vec3 from : {vec3(0.5f, 0.7f, 0.4f), vec3(0.0f, 0.0f, -1.0f)}) {
        VolumeRenderParams p = params(g, from, 56, band_tf(0.62f, 0.7f, 0.3f));
        p.dt = 0.37f;  // an odd lattice spacing
        check_exact(g, p, pool, 5.0);
    }
}

TEST_CASE("ess dvr: a camera inside the volume, early termination and t ranges", "[kd_dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = volume::sparse_nbody({48, 48, 48}, 11u);
    VolumeRenderParams p = params(g, vec3(0.3f, 0.2f, 1.0f), 48, volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    p.camera = Camera{vec3(20.0f, 25.0f, 30.0f), vec3(24.0f, 22.0f, 0.0f), {0.0f, 1.0f, 0.0f}, 70.0f}.frame(48, 48);
    p.alpha_stop = 0.3f;  // early termination cuts many rays
    double ratio = check_exact(g, p, pool, 2.0);
    CHECK(ratio < 1.0);
}

TEST_CASE("ess dvr: the occupancy holds every voxel whose neighbourhood can be visible", "[kd_dvr]") {
    ThreadPool pool(2);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::Dims dims{13, 9, 11};
    volume::DensityGrid g{dims, vec3(1.0f), std::vector<float>(volume::voxel_count(dims))};
    for (float& v : g.values) v = u(rng) < 0.97f ? u(rng) * 0.4f : u(rng) * 1.2f - 0.1f;  // also outside [0, 1]
    // Borders: clamped (out-of-grid neighbours repeat the edge), constant 0 (the default) and a
    // constant inside the visible band (every boundary voxel becomes visible).
    for (GridBorder border : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(0.44f)})
    for (std::size_t n : {std::size_t{256}, std::size_t{1024}}) {
        volume::TransferFunction band({{0.0f, vec4(0.0f)}, {0.41f, vec4(0.0f)}, {0.44f, vec4(0.8f, 0.6f, 0.2f, 0.5f)},
                                       {0.47f, vec4(0.0f)}, {1.0f, vec4(0.0f)}}, n);
        std::vector<std::uint32_t> tf = band.packed_rgba8();
        EssCodes codes = ess_codes(g, static_cast<std::uint32_t>(n), pool, border);
        auto neighbour = [&](std::int64_t x, std::int64_t y, std::int64_t z) -> double {
            bool inside = x >= 0 && y >= 0 && z >= 0 && x < dims.x && y < dims.y && z < dims.z;
            if (!inside && border.mode == BorderMode::Constant) return border.value;
            return g.clamped(x, y, z);
        };
        EssClassifier cls = ess_classifier(tf);
        const double last = double(n - 1);
        auto texel_alpha = [&](std::size_t i) { return double(tf[i] >> 24) / 255.0; };
        // Independent: the piecewise-linear table's alpha is > 0 somewhere in [a, b] iff it is at
        // a or at b, or at an entry position strictly inside.
        auto alpha_at = [&](double d) {
            d = std::clamp(d, 0.0, 1.0) * last;
            std::size_t i = std::min<std::size_t>(std::size_t(d), n - 1), j = std::min<std::size_t>(i + 1, n - 1);
            return texel_alpha(i) + (texel_alpha(j) - texel_alpha(i)) * (d - double(i));
        };
        auto visible = [&](double a, double b) {
            if (alpha_at(a) > 0.0 || alpha_at(b) > 0.0) return true;
            for (std::size_t i = 0; i < n; ++i)
                if (double(i) / last > a && double(i) / last < b && texel_alpha(i) > 0.0) return true;
            return false;
        };
        auto bucket = [&](double d) { return std::size_t(std::floor(std::clamp(d, 0.0, 1.0) * last)) * 256 / n; };
        double slack = (double(n / 256) + 1.0) / last + 1e-5;  // a bucket is n / 256 segments wide
        volume::Occupancy occ = ess_occupancy(codes, cls, pool);
        std::size_t visible_count = 0;
        for (std::uint32_t z = 0; z < dims.z; ++z)
            for (std::uint32_t y = 0; y < dims.y; ++y)
                for (std::uint32_t x = 0; x < dims.x; ++x) {
                    double lo = 1e9, hi = -1e9;
                    for (int dz = -1; dz <= 1; ++dz)
                        for (int dy = -1; dy <= 1; ++dy)
                            for (int dx = -1; dx <= 1; ++dx) {
                                double v = neighbour(std::int64_t{x} + dx, std::int64_t{y} + dy, std::int64_t{z} + dz);
                                lo = std::min(lo, v);
                                hi = std::max(hi, v);
                            }
                    std::size_t i = volume::voxel_index(dims, x, y, z);
                    std::uint32_t code = ess_code(codes, i);
                    INFO("border " << int(border.mode) << " " << border.value << ", " << n << " entries, voxel " << x << "," << y << "," << z << ": range " << lo << " .. " << hi
                           << ", code " << code);
                    REQUIRE((code & 255u) <= bucket(lo));
                    REQUIRE((code & 255u) >= bucket(lo - 1e-5));
                    REQUIRE((code >> 8) >= bucket(hi));
                    REQUIRE((code >> 8) <= bucket(hi + 1e-5));
                    bool ours = cls.visible(code);
                    if (visible(lo, hi)) REQUIRE(ours);                // conservative
                    if (ours) REQUIRE(visible(lo - slack, hi + slack));  // and by at most a bucket
                    REQUIRE(bool(occ.voxels[i]) == ours);
                    visible_count += ours;
                }
        CHECK(visible_count > 20);
        CHECK(visible_count < g.values.size() - 20);
    }
    // Threshold classification (256 entries): buckets whose segment reaches 0.5, i.e. 127 up.
    EssCodes codes = ess_codes(g, 256, pool);
    EssClassifier above = ess_threshold_classifier(0.5f, 256);
    CHECK(above.visible_buckets() == 129);
    for (std::size_t i = 0; i < g.values.size(); ++i)
        REQUIRE(above.visible(ess_code(codes, i)) == ((ess_code(codes, i) >> 8) >= 127u));
    // The classifier as the Rebuilder's per-value table sees it: code / 65535.
    EssClassifier cls = ess_classifier(volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    for (std::uint32_t code = 0; code < 65536; code += 7) REQUIRE(cls(float(code) / 65535.0f) == cls.visible(code));
}

TEST_CASE("ess dvr: classifying voxels by their own density and dilating misses a visible band", "[kd_dvr]") {
    // Voxels alternate between 0.2 and 0.8 inside a box; the TF is visible only near 0.5, which
    // no voxel holds but every trilinear blend between the two values passes through.
    ThreadPool pool(2);
    volume::Dims dims{24, 20, 22};
    volume::DensityGrid g{dims, vec3(1.0f), std::vector<float>(volume::voxel_count(dims), 0.0f)};
    for (std::uint32_t z = 6; z < 16; ++z)
        for (std::uint32_t y = 5; y < 15; ++y)
            for (std::uint32_t x = 7; x < 17; ++x) g.values[volume::voxel_index(dims, x, y, z)] = (x + y + z) % 2 ? 0.8f : 0.2f;
    volume::TransferFunction tf = volume::TransferFunction({{0.0f, {0.0f, 0.0f, 0.0f, 0.0f}},
                                                            {0.44f, {0.5f, 0.5f, 0.5f, 0.0f}},
                                                            {0.5f, {0.5f, 0.5f, 0.5f, 0.6f}},
                                                            {0.56f, {0.5f, 0.5f, 0.5f, 0.0f}},
                                                            {1.0f, {0.0f, 0.0f, 0.0f, 0.0f}}});
    VolumeRenderParams p = params(g, vec3(0.3f, 0.5f, 1.0f), 48, tf.packed_rgba8());
    GridWords gw = GridWords::from(g);
    Frame ref = render_dvr_cpu(gw, p, pool);
    REQUIRE(summed_alpha(ref) > 10.0);
    auto naive_src = volume::classified(g, volume::TransferFunctionAlpha(tf));
    volume::Occupancy naive = volume::dilate(volume::classify(naive_src, pool), 1, pool);
    CHECK(naive.count() == 0);  // no voxel's own density is visible
    Frame missed = render_kd_dvr_cpu(gw, kdtree::encode(kdtree::build_vidal(naive, kdtree::Config::deep())), p, pool);
    CHECK(bitwise_differing(ref, missed) > 100);

    check_exact(g, p, pool, 10.0);
}

TEST_CASE("ess dvr: a lattice sample on a face shared by two leaves is taken once, none is lost", "[kd_dvr]") {
    // Every voxel visible: the deep tree's leaves tile the grid with shared faces, and the ESS
    // marcher must take exactly the marcher's samples on every ray, among them rays along the
    // axes whose lattice points fall exactly on the leaves' faces (dt = 0.5, faces every 8).
    ThreadPool pool(2);
    volume::Dims dims{32, 32, 32};
    volume::DensityGrid g = volume::constant_box(dims, 0.5f);
    GridWords gw = GridWords::from(g);
    std::vector<std::uint32_t> tf(256, rgba8(0.6f, 0.5f, 0.4f, 0.01f));
    volume::Occupancy occ = occupancy_for(g, tf, pool);
    REQUIRE(occ.count() == g.values.size());
    kdtree::Tree t = kdtree::build_vidal(occ, kdtree::Config::deep());
    REQUIRE(t.leaves.size() >= 64);
    std::vector<std::uint32_t> words = kdtree::encode(t);

    VolumeRenderParams p;
    p.tf = tf;
    p.dt = 0.5f;
    p.alpha_stop = 2.0f;  // never stop: every sample counts
    std::vector<std::uint32_t> pw = kd_dvr_params(gw, words, p);
    shared::Words pws{pw.data(), pw.size()}, kw{words.data(), words.size()}, gws{gw.words.data(), gw.words.size()},
        tw{tf.data(), tf.size()};
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pws);

    std::vector<Ray> rays;
    for (float y : {3.25f, 8.0f, 16.0f, 23.5f})
        for (float z : {0.5f, 8.0f, 11.75f}) {
            rays.push_back({vec3(-4.0f, y, z), vec3(1.0f, 0.0f, 0.0f)});
            rays.push_back({vec3(36.0f, z, y), vec3(-1.0f, 0.0f, 0.0f)});
            rays.push_back({vec3(y, z, -8.0f), vec3(0.0f, 0.0f, 1.0f)});
            rays.push_back({vec3(y, 40.0f, z), vec3(0.0f, -1.0f, 0.0f)});
        }
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        vec3 o = vec3(16.0f) + vec3(u(rng), u(rng), u(rng)) * 40.0f, target = vec3(16.0f) + vec3(u(rng), u(rng), u(rng)) * 16.0f;
        if (i % 5 == 0) o = vec3(16.0f) + vec3(u(rng), u(rng), u(rng)) * 16.0f;  // inside
        rays.push_back({o, target - o});
    }
    std::size_t on_face_rays = 0;
    for (const Ray& r : rays) {
        std::uint32_t ref_steps, ess_steps, status;
        vec4 a = shared::sylva_dvr_march(gws, tw, sp, r.origin, r.direction, 0.0f, shared::sylva_inf(), ref_steps);
        vec4 b = shared::sylva_kd_dvr_march(kw, gws, tw, sp, r.origin, r.direction, 0.0f, shared::sylva_inf(), ess_steps,
                                            status);
        // Iterator steps of the same (normalised) ray, counted separately.
        kdtree::LeafIterator it(words, Ray{r.origin, shared::sylva_dvr_unit(r.direction)}, Interval{});
        std::size_t leaves = 0;
        while (it.next()) ++leaves;
        INFO("ray " << r.origin.x << "," << r.origin.y << "," << r.origin.z << " dir " << r.direction.x << ","
                    << r.direction.y << "," << r.direction.z << ": " << leaves << " leaves");
        REQUIRE(status == SYLVA_ITER_DONE);
        REQUIRE(ess_steps - it.steps() == ref_steps);  // samples = the marcher's, each once
        REQUIRE(std::memcmp(&a, &b, sizeof a) == 0);
        on_face_rays += (leaves >= 4 && (r.direction.x == 1.0f || r.direction.z == 1.0f)) ? 1 : 0;
    }
    CHECK(on_face_rays >= 24);  // axis rays crossing >= 3 shared faces at lattice points
}

TEST_CASE("ess dvr: images equal the marcher's under each border mode, data touching the grid's faces", "[kd_dvr]") {
    ThreadPool pool(2);
    // Density rising towards the faces (up to 0.9 on them) with an empty core: the boundary
    // voxels decide what a border changes.
    volume::Dims dims{24, 20, 18};
    volume::DensityGrid g{dims, vec3(1.0f, 1.2f, 0.9f), std::vector<float>(volume::voxel_count(dims))};
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) {
                float e = std::min({float(x), float(dims.x - 1 - x), float(y), float(dims.y - 1 - y), float(z),
                                    float(dims.z - 1 - z)});
                g.values[volume::voxel_index(dims, x, y, z)] = e < 3.0f ? 0.9f - 0.2f * e : 0.0f;
            }
    std::vector<Frame> refs;
    for (GridBorder border : {GridBorder::clamp(), GridBorder{}, GridBorder::constant(0.44f)}) {
        for (vec3 from : {vec3(0.4f, 0.3f, 1.0f), vec3(1.0f, 0.0f, 0.0f), vec3(-0.3f, -0.9f, 0.2f)}) {
            INFO("border " << int(border.mode) << " " << border.value << ", view from " << from.x << "," << from.y << ","
                           << from.z);
            // A band TF that sees 0.44 (the third border) and the faces' 0.5 .. 0.9 only in part.
            VolumeRenderParams p = params(g, from, 48, band_tf(0.4f, 0.6f, 0.3f));
            p.shading = from.x > 0.3f;  // the gradient reads the border too
            check_exact(g, p, pool, 1.0, border);
            if (from.z > 0.5f) refs.push_back(render_dvr_cpu(GridWords::from(g, border), p, pool));
        }
    }
    // The borders change the image (the test above compares what differs).
    REQUIRE(refs.size() == 3);
    CHECK(bitwise_differing(refs[0], refs[1]) > 0);
    CHECK(bitwise_differing(refs[1], refs[2]) > 0);
}

TEST_CASE("ess dvr: EssRebuilder (block ranges for binned trees, segment codes for others) gives the fresh trees after TF changes",
          "[kd_dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = volume::sparse_nbody({40, 44, 36}, 6u);
    GridWords gw = GridWords::from(g);
    std::vector<std::pair<std::string, std::vector<std::uint32_t>>> tfs = {
        {"ct", volume::TransferFunction::ct_bone_tissue().packed_rgba8()},
        {"band", band_tf(0.3f, 0.36f, 0.4f)},
        {"ramp, 1024 entries", volume::TransferFunction::ramp(0.2f, 0.6f, vec4(1.0f, 0.8f, 0.5f, 0.6f), 1024).packed_rgba8()},
        {"nothing visible", std::vector<std::uint32_t>(256, rgba8(1.0f, 1.0f, 1.0f, 0.0f))},
        {"ct again", volume::TransferFunction::ct_bone_tissue().packed_rgba8()}};
    for (kdtree::Config cfg : {kdtree::Config::shallow(), kdtree::Config::deep(), kdtree::Config::deep().binned()}) {
        EssRebuilder<ThreadPool> ess(g, cfg, pool);
        std::uint32_t entries = 0;
        for (const auto& [tf_name, tf] : tfs) {
            INFO(tf_name << ", " << (cfg.planes == kdtree::Planes::Binned ? "binned" : "vidal") << " max depth "
                         << cfg.max_depth);
            kdtree::Tree t = ess.rebuild(tf);
            volume::Occupancy occ = occupancy_for(g, tf, pool);
            kdtree::Tree fresh = cfg.planes == kdtree::Planes::Binned ? kdtree::build_binned(occ, cfg, pool)
                                                                      : kdtree::build_vidal(occ, cfg);
            CHECK(t.nodes == fresh.nodes);
            CHECK(t.stats.occupied == occ.count());
            if (cfg.planes == kdtree::Planes::Binned) {
                CHECK(ess.codes_ms() == 0.0);  // binned: no codes, the block ranges once
                CHECK((ess.ranges_ms() > 0.0) == (entries == 0));
                REQUIRE(ess.block_ranges() != nullptr);
                CHECK(ess.timings().blocks_read <= ess.block_ranges()->lo.size());
            } else {
                CHECK((ess.codes_ms() > 0.0) == (tf.size() != entries));  // codes only for a new entry count
                CHECK(ess.ranges_ms() == 0.0);
            }
            entries = static_cast<std::uint32_t>(tf.size());
            if (tf_name == "nothing visible") {
                CHECK(t.nodes.empty());
                continue;
            }
            VolumeRenderParams p = params(g, vec3(0.3f, 0.6f, 1.0f), 40, tf);
            Frame ref = render_dvr_cpu(gw, p, pool), ess_img = render_kd_dvr_cpu(gw, kdtree::encode(t), p, pool);
            CHECK(summed_alpha(ref) > 1.0);
            CHECK(bitwise_differing(ref, ess_img) == 0);
        }
    }
}

TEST_CASE("ess dvr: block ranges and the undecided blocks' voxels give the segment codes' occupancy voxel for voxel",
          "[kd_dvr]") {
    ThreadPool pool(2);
    std::vector<std::pair<std::string, std::vector<std::uint32_t>>> tfs = block_pass_tfs();
    std::vector<std::pair<std::string, GridBorder>> borders = block_pass_borders();
    // Grids whose sides are and are not multiples of the 8-voxel block, down to one voxel.
    // Sparse blobs, and Marschner-Lobb: smooth, so neighbourhood ranges are narrow and lie
    // next to every run boundary of the TFs (a boundary off by 0.01 fails).
    for (volume::Dims dims : {volume::Dims{40, 44, 36}, volume::Dims{17, 9, 23}, volume::Dims{8, 8, 8},
                              volume::Dims{1, 1, 1}, volume::Dims{1, 12, 3}, volume::Dims{33, 30, 27}}) {
        volume::DensityGrid g = dims.x == 33 ? volume::marschner_lobb(dims) : volume::sparse_nbody(dims, 6u);
        EssBlockRanges r = ess_block_ranges(g, pool);
        REQUIRE(r.lo.size() == std::size_t{r.blocks.x} * r.blocks.y * r.blocks.z);
        // The grown ranges against brute force over each block grown by one voxel.
        std::size_t range_mismatches = 0;
        for (std::uint32_t b = 0; b < r.lo.size(); ++b) {
            uvec3 c(b % r.blocks.x, (b / r.blocks.x) % r.blocks.y, b / (r.blocks.x * r.blocks.y));
            float lo = INFINITY, hi = -INFINITY;
            for (std::uint32_t z = c.z * 8 > 0 ? c.z * 8 - 1 : 0; z < std::min(dims.z, c.z * 8 + 9); ++z)
                for (std::uint32_t y = c.y * 8 > 0 ? c.y * 8 - 1 : 0; y < std::min(dims.y, c.y * 8 + 9); ++y)
                    for (std::uint32_t x = c.x * 8 > 0 ? c.x * 8 - 1 : 0; x < std::min(dims.x, c.x * 8 + 9); ++x) {
                        float v = g.values[volume::voxel_index(dims, x, y, z)];
                        lo = std::min(lo, v), hi = std::max(hi, v);
                    }
            range_mismatches += (lo != r.lo[b] || hi != r.hi[b]) ? 1u : 0u;
        }
        CHECK(range_mismatches == 0);
        for (const auto& [bname, border] : borders)
            for (const auto& [tf_name, tf] : tfs) {
                INFO(dims.x << "x" << dims.y << "x" << dims.z << ", border " << bname << ", " << tf_name);
                EssClassifier cls = ess_classifier(tf);
                volume::Occupancy ref = occupancy_for(g, tf, pool, border);
                std::vector<std::uint8_t> verdicts;
                ess_block_verdicts(r, cls, border, verdicts);
                std::size_t wrong_verdicts = 0, decided = 0;
                for (std::uint32_t z = 0; z < dims.z; ++z)
                    for (std::uint32_t y = 0; y < dims.y; ++y)
                        for (std::uint32_t x = 0; x < dims.x; ++x) {
                            std::uint8_t want = ref.voxels[volume::voxel_index(dims, x, y, z)];
                            std::uint8_t v = verdicts[x / 8 + r.blocks.x * (y / 8 + std::size_t{r.blocks.y} * (z / 8))];
                            if (v != kdtree::kBlockRead) ++decided;
                            if ((v == kdtree::kBlockEmpty && want != 0) || (v == kdtree::kBlockFull && want != 1)) ++wrong_verdicts;
                        }
                // The block words: from the verdicts and the undecided blocks' voxels, and with
                // every block read voxel by voxel, against the words of the codes' occupancy.
                std::vector<std::uint32_t> want_words, words, all_read_words;
                kdtree::block_words(ref, pool, want_words);
                ess_block_words(g, cls, border, verdicts, pool, words);
                ess_block_words(g, cls, border, std::vector<std::uint8_t>(verdicts.size(), kdtree::kBlockRead), pool,
                                all_read_words);
                CHECK(words == want_words);
                CHECK(all_read_words == want_words);
                CHECK(wrong_verdicts == 0);
                if (tf_name == "all visible" || tf_name == "nothing visible") CHECK(decided == ref.voxels.size());
                // The whole binned build from block ranges equals the binned tree of the codes' occupancy.
                EssRebuilder<ThreadPool> ess(g, kdtree::Config::deep().binned(), pool, border);
                kdtree::Tree t = ess.rebuild(cls), fresh = kdtree::build_binned(ref, kdtree::Config::deep().binned(), pool);
                CHECK(t.nodes == fresh.nodes);
                CHECK(t.stats.occupied == ref.count());
                // The same from grid words (native-format path) with the same border.
                GridWords gw = GridWords::from(g, border);
                std::vector<std::uint32_t> gw_words;
                ess_block_words(gw, cls, verdicts, pool, gw_words);
                CHECK(gw_words == want_words);
                EssRebuilder<ThreadPool> ess_w(gw, kdtree::Config::deep().binned(), pool);
                CHECK(ess_w.rebuild(cls).nodes == fresh.nodes);
            }
    }
    // Infinite densities (allowed; NaN is not) classify as the codes do: +inf as density 1, -inf as 0.
    volume::DensityGrid inf_grid = volume::sparse_nbody({20, 18, 22}, 3u);
    // Boxes of them, so that whole neighbourhoods are infinite (one at a corner of the grid).
    auto fill = [&](uvec3 lo, uvec3 hi, float v) {
        for (std::uint32_t z = lo.z; z < hi.z; ++z)
            for (std::uint32_t y = lo.y; y < hi.y; ++y)
                for (std::uint32_t x = lo.x; x < hi.x; ++x) inf_grid.values[volume::voxel_index(inf_grid.dims, x, y, z)] = v;
    };
    fill(uvec3(4, 5, 6), uvec3(9, 10, 11), INFINITY);
    fill(uvec3(0, 15, 19), uvec3(3, 18, 22), INFINITY);
    fill(uvec3(12, 1, 9), uvec3(17, 6, 14), -INFINITY);
    for (const auto& [tf_name, tf] : tfs) {
        INFO("infinities, " << tf_name);
        volume::Occupancy ref = occupancy_for(inf_grid, tf, pool);
        kdtree::Tree t = EssRebuilder<ThreadPool>(inf_grid, kdtree::Config::deep().binned(), pool).rebuild(tf);
        CHECK(t.nodes == kdtree::build_binned(ref, kdtree::Config::deep().binned(), pool).nodes);
        std::vector<std::uint32_t> want_words, all_read_words;
        kdtree::block_words(ref, pool, want_words);
        uvec3 nb = kdtree::block_counts(inf_grid.dims);
        ess_block_words(inf_grid, ess_classifier(tf), GridBorder{},
                        std::vector<std::uint8_t>(std::size_t{nb.x} * nb.y * nb.z, kdtree::kBlockRead), pool, all_read_words);
        CHECK(all_read_words == want_words);
    }
    volume::DensityGrid nan_grid = volume::sparse_nbody({20, 20, 20}, 2u);
    nan_grid.values[volume::voxel_index(nan_grid.dims, 11, 3, 17)] = std::nanf("");
    CHECK_THROWS_WITH(ess_block_ranges(nan_grid, pool), Catch::Contains("NaN density"));
    EssRebuilder<ThreadPool> nan_ess(nan_grid, kdtree::Config::deep().binned(), pool);
    CHECK_THROWS_WITH(nan_ess.rebuild(volume::TransferFunction::ct_bone_tissue().packed_rgba8()),
                      Catch::Contains("NaN density"));
}

TEST_CASE("ess dvr: native uint8 / uint16 grids, read as their raw voxels, give the occupancy of their densities",
          "[kd_dvr]") {
    ThreadPool pool(2);
    std::vector<std::pair<std::string, std::vector<std::uint32_t>>> tfs = block_pass_tfs();
    std::vector<std::pair<std::string, GridBorder>> borders = block_pass_borders();
    for (volume::Dims dims : {volume::Dims{40, 44, 36}, volume::Dims{17, 9, 23}, volume::Dims{1, 1, 1},
                              volume::Dims{1, 12, 3}, volume::Dims{33, 30, 27}})
        for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
            volume::DensityGrid source = dims.x == 33 ? volume::marschner_lobb(dims) : volume::sparse_nbody(dims, 6u);
            volume::Volume raw = kdtest::quantised(source, type);
            volume::DensityGrid g = volume::normalize(raw);  // the densities the native grid's samplers read
            INFO(dims.x << "x" << dims.y << "x" << dims.z << ", " << volume::scalar_name(type));
            if (g.values.size() >= 1000) {  // both plateaus hold voxels
                CHECK(std::count(g.values.begin(), g.values.end(), 0.0f) > 0);
                CHECK(std::count(g.values.begin(), g.values.end(), 1.0f) > 0);
            }
            for (const auto& [bname, border] : borders) {
                GridWords gw = GridWords::native(raw, border), gf = GridWords::from(g, border);
                REQUIRE(gw.sampling.format == (type == volume::ScalarType::U8 ? GridFormat::U8 : GridFormat::U16));
                std::size_t density_mismatches = 0;
                for (std::size_t i = 0; i < g.values.size(); ++i) density_mismatches += gw.density(i) != g.values[i];
                REQUIRE(density_mismatches == 0);
                // The ranges of the raw voxels, as densities, are those of the floats.
                EssBlockRanges r = ess_block_ranges(gw, pool), rf = ess_block_ranges(g, pool);
                CHECK(r.lo == rf.lo);
                CHECK(r.hi == rf.hi);
                for (const auto& [tf_name, tf] : tfs) {
                    INFO("border " << bname << ", " << tf_name);
                    EssClassifier cls = ess_classifier(tf);
                    volume::Occupancy ref = occupancy_for(g, tf, pool, border);
                    std::vector<std::uint32_t> want_words, words, all_read_words, float_words;
                    kdtree::block_words(ref, pool, want_words);
                    std::vector<std::uint8_t> verdicts;
                    ess_block_verdicts(r, cls, border, verdicts);
                    ess_block_words(gw, cls, verdicts, pool, words);
                    ess_block_words(gw, cls, std::vector<std::uint8_t>(verdicts.size(), kdtree::kBlockRead), pool,
                                    all_read_words);
                    ess_block_words(gf, cls, verdicts, pool, float_words);
                    CHECK(words == want_words);
                    CHECK(all_read_words == want_words);
                    CHECK(float_words == want_words);
                    kdtree::Tree t = EssRebuilder<ThreadPool>(gw, kdtree::Config::deep().binned(), pool).rebuild(cls);
                    CHECK(t.nodes == kdtree::build_binned(ref, kdtree::Config::deep().binned(), pool).nodes);
                    CHECK(t.stats.occupied == ref.count());
                }
            }
        }
}

TEST_CASE("ess dvr: aneurism, shallow and deep trees of both builders, images equal the marcher's",
          "[kd_dvr][data]") {
    std::string path = kdtest::data_file("aneurism_256x256x256_uint8.raw");
    if (path.empty()) return;
    ThreadPool pool(2);
    volume::DensityGrid g = volume::normalize(volume::read_raw(path, volume::parse_raw_name(path)));
    VolumeRenderParams p = params(g, vec3(0.4f, 0.3f, 1.0f), 96, volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    p.shading = true;
    double ratio = check_exact(g, p, pool, 50.0);
    CHECK(ratio < 0.5);
}

TEST_CASE("ess dvr: trees that do not fit the grid are refused, corrupt trees are flagged", "[kd_dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = volume::sparse_nbody({24, 24, 24}, 2u);
    GridWords gw = GridWords::from(g);
    VolumeRenderParams p = params(g, vec3(0.4f, 0.3f, 1.0f), 16, volume::TransferFunction::ct_bone_tissue().packed_rgba8());
    kdtree::Tree t = kdtree::build_vidal(occupancy_for(g, p.tf, pool), kdtree::Config::deep());
    std::vector<std::uint32_t> words = kdtree::encode(t);
    CHECK_NOTHROW(render_kd_dvr_cpu(gw, words, p, pool));

    volume::DensityGrid other = volume::sparse_nbody({24, 24, 20}, 2u);
    CHECK_THROWS_WITH(render_kd_dvr_cpu(GridWords::from(other), words, p, pool), Catch::Contains("kd-tree's grid is"));
    kdtree::Tree moved = t;
    moved.origin = vec3(1.0f, 0.0f, 0.0f);
    CHECK_THROWS_WITH(render_kd_dvr_cpu(gw, kdtree::encode(moved), p, pool), Catch::Contains("origin must be 0"));
    kdtree::Tree stretched = t;
    stretched.spacing = vec3(1.0f, 2.0f, 1.0f);
    CHECK_THROWS_WITH(render_kd_dvr_cpu(gw, kdtree::encode(stretched), p, pool), Catch::Contains("spacing"));
    std::vector<std::uint32_t> junk(64, 7u);
    CHECK_THROWS_WITH(render_kd_dvr_cpu(gw, junk, p, pool), Catch::Contains("not a valid encoded kd-tree"));
    CHECK_THROWS_WITH(ess_classifier(std::vector<std::uint32_t>{5u}), Catch::Contains("2 to 2^24 entries"));
    volume::DensityGrid nan_grid = g;
    nan_grid.values[1234] = std::nanf("");
    CHECK_THROWS_WITH(ess_codes(nan_grid, 256, pool), Catch::Contains("NaN density"));
    CHECK_THROWS_WITH(ess_occupancy(ess_codes(g, 256, pool), ess_classifier(std::vector<std::uint32_t>(300, 0u)), pool),
                      Catch::Contains("codes made for a TF of 256 entries"));

    // A child link pointing back at its parent: the rays that reach it report 0xFFFFFFFF steps.
    REQUIRE(t.nodes.size() > 3);
    std::vector<std::uint32_t> bad = words;
    bad[SYLVA_KD_HEADER_WORDS + 3] = (bad[SYLVA_KD_HEADER_WORDS + 3] & 3u);  // root's lower child := 0
    Frame f = render_kd_dvr_cpu(gw, bad, p, pool);
    std::size_t flagged = 0;
    for (std::uint32_t s : f.steps) flagged += s == 0xFFFFFFFFu;
    CHECK(flagged > 0);
}
