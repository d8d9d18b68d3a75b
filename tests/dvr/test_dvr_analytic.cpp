// The volume integrators on the host against analytic and independent references: TF lookup,
// trilinear sampling, the closed form of a constant-density volume, the exact integral of a
// linear ramp, the shared sample lattice, and iso-surface hit distances.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include <sylva/bih/query.hpp>

#include "dvr_fixtures.hpp"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

shared::SylvaDvrParams params_of(const std::vector<std::uint32_t>& words) {
    return shared::sylva_dvr_params(shared::Words{words.data(), words.size()});
}

/// Reference trilinear interpolation with the cell convention of volume/grid.hpp, in double.
double trilinear_ref(const volume::DensityGrid& g, glm::dvec3 p) {
    glm::dvec3 u = p / glm::dvec3(g.spacing) - 0.5;
    double acc = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        double w = 1.0;
        std::int64_t idx[3];
        for (int a = 0; a < 3; ++a) {
            double ua = std::clamp(u[a], 0.0, double(g.dims[a] - 1));
            double fl = std::floor(ua), fr = ua - fl;
            bool hi = (corner >> a) & 1;
            idx[a] = std::int64_t(fl) + (hi ? 1 : 0);
            w *= hi ? fr : 1.0 - fr;
        }
        if (w != 0.0) acc += w * g.clamped(idx[0], idx[1], idx[2]);
    }
    return acc;
}

}  // namespace

TEST_CASE("TF lookup interpolates linearly between entries and clamps", "[dvr]") {
    std::vector<std::uint32_t> tf{rgba8(0, 10, 255, 0), rgba8(100, 20, 55, 255), rgba8(200, 30, 5, 51)};
    shared::Words w{tf.data(), tf.size()};
    vec4 q = shared::sylva_tf_lookup(w, 3, 0.25f);  // halfway between entries 0 and 1
    CHECK(q.r == Approx(50.0 / 255).epsilon(1e-6));
    CHECK(q.g == Approx(15.0 / 255).epsilon(1e-6));
    CHECK(q.b == Approx(155.0 / 255).epsilon(1e-6));
    CHECK(q.a == Approx(127.5 / 255).epsilon(1e-6));
    vec4 e = shared::sylva_tf_lookup(w, 3, 0.875f);  // 3/4 of the way from entry 1 to 2
    CHECK(e.a == Approx((255 + 0.75 * (51 - 255)) / 255).epsilon(1e-6));
    CHECK(shared::sylva_tf_lookup(w, 3, -3.0f) == shared::sylva_tf_texel(tf[0]));
    CHECK(shared::sylva_tf_lookup(w, 3, 7.0f) == shared::sylva_tf_texel(tf[2]));
    CHECK(shared::sylva_tf_lookup(w, 3, std::nanf("")) == shared::sylva_tf_texel(tf[0]));
    CHECK(shared::sylva_tf_lookup(w, 0, 0.5f) == vec4(0.0f));
}

TEST_CASE("Trilinear samples and central-difference gradients match an independent reference", "[dvr]") {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::DensityGrid g{{5, 4, 3}, {1.0f, 0.5f, 2.0f}, {}};
    for (int i = 0; i < 60; ++i) g.values.push_back(u(rng));
    GridWords gw = GridWords::from(g);
    shared::Words w{gw.words.data(), gw.words.size()};
    vec3 hi = vec3(g.dims) * g.spacing;
    for (int i = 0; i < 2000; ++i) {
        vec3 p = (vec3(u(rng), u(rng), u(rng)) * 1.4f - 0.2f) * hi;  // also outside the box
        float d = shared::sylva_grid_density(w, g.dims, g.spacing, p);
        REQUIRE(d == Approx(trilinear_ref(g, p)).margin(1e-6));
        vec3 grad = shared::sylva_grid_gradient(w, g.dims, g.spacing, p);
        for (int a = 0; a < 3; ++a) {
            glm::dvec3 e(0.0);
            e[a] = g.spacing[a];
            double ref = 0.5 * (trilinear_ref(g, glm::dvec3(p) + e) - trilinear_ref(g, glm::dvec3(p) - e));
            REQUIRE(grad[a] == Approx(ref).margin(2e-6));
        }
    }
    // Voxel centres give the voxel values exactly.
    CHECK(shared::sylva_grid_density(w, g.dims, g.spacing, vec3(2.5f, 1.25f, 3.0f)) == g.at(2, 2, 1));
}

TEST_CASE("Constant density: marcher and single-sample BIH-DVR match 1 - (1 - alpha)^(L / unit)", "[dvr]") {
    // A grid of constant density 0.5 and a constant TF: along a chord of length L the exact
    // opacity is 1 - (1 - a)^(L / unit) and the colour c times it. 16 x 8 x 4 voxels keep the
    // 16-bit planes exact (multiples of 1/16 of the root box).
    volume::DensityGrid g = sample_grid({16, 8, 4}, {1.0f, 1.5f, 0.75f}, [](glm::dvec3) { return 0.5; });
    const double a = 77.0 / 255.0, unit = 2.0;
    const glm::dvec3 colour = glm::dvec3(200, 100, 50) / 255.0;
    VolumeRenderParams p;
    p.tf = std::vector<std::uint32_t>(256, rgba8(200, 100, 50, 77));
    p.unit = float(unit);
    p.alpha_stop = 2.0f;  // no early termination
    GridWords gw = GridWords::from(g);
    auto cuboids = grid_cuboids(g, 0.1f);
    REQUIRE(cuboids.size() == 512);
    auto rays = rays_into(gw.world_box(), 300, 5);
    std::size_t hits = 0;
    for (bih::NodeFormat fmt : {bih::NodeFormat::Float32, bih::NodeFormat::Fixed16}) {
        auto words = encode_voxels(cuboids, fmt);
        p.mode = VolumeMode::BihSingle;
        auto bp = params_of(bih_dvr_params(VoxelBihView{words, {}, g.spacing, gw.world_box()}, p));
        p.mode = VolumeMode::DvrReference;
        auto mp = params_of(dvr_params(gw, p));
        shared::Words bw{words.data(), words.size()}, gwords{gw.words.data(), gw.words.size()}, tw{p.tf.data(), p.tf.size()};
        for (const Ray& r : rays) {
            auto c = chord(r, gw.world_box());
            double L = c ? c->second - c->first : 0.0;
            double closed = 1.0 - std::pow(1.0 - a, L / unit);
            std::uint32_t steps, status;
            vec4 s = shared::sylva_bih_dvr_single(bw, tw, bp, r.origin, r.direction, 0.0f, shared::sylva_inf(), steps, status);
            INFO("ray o=(" << r.origin.x << "," << r.origin.y << "," << r.origin.z << ") L=" << L);
            REQUIRE(status == SYLVA_ITER_DONE);
            REQUIRE(s.a == Approx(closed).margin(2e-6));
            REQUIRE(s.r == Approx(colour.r * closed).margin(2e-6));
            REQUIRE(s.b == Approx(colour.b * closed).margin(2e-6));
            // The marcher takes N lattice samples of length dt: exactly 1 - (1 - a)^(N dt / unit),
            // which is the closed form up to one dt of chord.
            vec4 m = shared::sylva_dvr_march(gwords, tw, mp, r.origin, r.direction, 0.0f, shared::sylva_inf(), steps);
            std::size_t n = 0;
            if (c)
                for (std::int64_t k = std::int64_t(std::floor(c->first / mp.dt)) - 2; float(k) * mp.dt < c->second; ++k)
                    n += (k >= 0 && float(k) * mp.dt >= c->first) ? 1 : 0;
            REQUIRE(steps == n);
            double lattice = 1.0 - std::pow(1.0 - a, double(n) * mp.dt / unit);
            REQUIRE(m.a == Approx(lattice).margin(2e-6));
            REQUIRE(m.g == Approx(colour.g * lattice).margin(2e-6));
            double slope = std::log(1.0 / (1.0 - a)) / unit * (1.0 - closed);
            REQUIRE(std::abs(m.a - closed) <= slope * mp.dt + 1e-6);
            hits += L > 0.0 ? 1 : 0;
        }
    }
    CHECK(hits > 400);
}

TEST_CASE("Linear ramp: single-sample BIH-DVR over single-voxel leaves equals the exact integral", "[dvr]") {
    // d(x) = 0.15 + 0.7 (n . x) / (n . box_hi) is linear, so each voxel's linear reconstruction
    // (centre value + gradient by central differences of d) is d itself, and the mean density
    // of a leaf segment is the density at its middle. The TF has alpha(d) = d and colour
    // (d, 1 - d, 64/255) exactly (entry i holds i), so the only approximation left is the
    // piecewise-constant extinction per leaf (second order in the ~0.02 density change per
    // leaf) and the 14/16-bit payload quantisation. Stated tolerance: 3e-4 on every channel
    // (measured 1.6e-4; evaluating at the segment start instead of its middle gives ~1e-2).
    volume::Dims dims{24, 20, 16};
    vec3 spacing{1.0f, 1.0f, 1.25f};
    glm::dvec3 n = glm::normalize(glm::dvec3(1.0, 0.6, 0.3));
    double top = glm::dot(n, glm::dvec3(dims) * glm::dvec3(spacing));
    Field ramp = [=](glm::dvec3 x) { return 0.15 + 0.7 * glm::dot(n, x) / top; };
    volume::DensityGrid g = sample_grid(dims, spacing, ramp);
    auto words = encode_voxels(field_cuboids(g, ramp), bih::NodeFormat::Float32);
    VolumeRenderParams p;
    for (std::uint32_t i = 0; i < 256; ++i) p.tf.push_back(rgba8(i, 255 - i, 64, i));
    p.unit = 20.0f;
    p.alpha_stop = 2.0f;
    p.mode = VolumeMode::BihSingle;
    Aabb box = g.world_box();
    auto sp = params_of(bih_dvr_params(VoxelBihView{words, {}, spacing, box}, p));
    shared::Words bw{words.data(), words.size()}, tw{p.tf.data(), p.tf.size()};
    double worst = 0.0, total = 0.0;
    for (const Ray& r : rays_into(box, 200, 9)) {
        std::uint32_t steps, status;
        vec4 s = shared::sylva_bih_dvr_single(bw, tw, sp, r.origin, r.direction, 0.0f, shared::sylva_inf(), steps, status);
        glm::dvec4 ref = reference_integral(r, box, ramp, p.tf, p.unit, 4000);
        for (int k = 0; k < 4; ++k) worst = std::max(worst, std::abs(double(s[k]) - ref[k]));
        total += ref.a;
    }
    INFO("worst channel difference " << worst);
    CHECK(worst <= 3e-4);
    CHECK(total > 40.0);  // the rays really cross the volume (mean opacity > 0.2)
}

TEST_CASE("Multi-sample BIH-DVR samples exactly the marcher's lattice positions", "[dvr]") {
    // Every voxel is a leaf (float32 planes): the leaves tile the grid box, so the lattice
    // indices each leaf owns (t0 <= k dt < t1), concatenated in leaf order, must be exactly
    // the marcher's, also when dt is longer than a voxel and some leaves get no sample.
    volume::DensityGrid g = sample_grid({12, 10, 8}, {1.0f, 1.2f, 0.8f}, blobs({12.0f, 12.0f, 6.4f}));
    for (float& v : g.values) v = std::max(v, 0.05f);
    auto words = encode_voxels(grid_cuboids(g, 0.0f), bih::NodeFormat::Float32);
    GridWords gw = GridWords::from(g);
    for (float dt : {default_dt(g.world_box()), 0.37f, 1.7f}) {
        std::size_t samples = 0, empty_leaves = 0;
        for (const Ray& r : rays_into(gw.world_box(), 300, 3)) {
            vec3 d = shared::sylva_dvr_unit(r.direction);
            vec2 span = shared::sylva_dvr_clip(vec3(0.0f), gw.world_box().hi, r.origin, d, 0.0f, shared::sylva_inf());
            std::vector<std::uint32_t> march, multi;
            if (span.x <= span.y)
                for (std::uint32_t k = shared::sylva_lattice_first(span.x, dt); shared::sylva_lattice_t(k, dt) < span.y; ++k)
                    march.push_back(k);
            bih::LeafIterator it(words, Ray{r.origin, d});
            while (auto leaf = it.next()) {
                std::size_t before = multi.size();
                for (std::uint32_t k = shared::sylva_lattice_first(leaf->t.t0, dt);
                     shared::sylva_lattice_t(k, dt) < leaf->t.t1; ++k)
                    multi.push_back(k);
                empty_leaves += (multi.size() == before) ? 1 : 0;
            }
            REQUIRE(it.status() == SYLVA_ITER_DONE);
            REQUIRE(march == multi);
            samples += march.size();
        }
        INFO("dt " << dt);
        CHECK(samples > 1000);
        if (dt > 1.5f) CHECK(empty_leaves > 100);
    }
}

TEST_CASE("Multi-sample BIH-DVR equals the marcher where both reconstruct the same density", "[dvr]") {
    // Constant density: both take the same samples with the same value, so the images agree to
    // rounding; one lattice sample more or less would change alpha by ~1e-2.
    volume::DensityGrid g = sample_grid({16, 8, 8}, {1.0f, 1.0f, 1.0f}, [](glm::dvec3) { return 0.6; });
    auto words = encode_voxels(grid_cuboids(g, 0.1f), bih::NodeFormat::Float32);
    GridWords gw = GridWords::from(g);
    SerialExecutor serial;
    VolumeRenderParams p;
    p.camera = Camera::framing(gw.world_box(), {0.3f, 0.5f, 1.0f}).frame(48, 40);
    p.width = 48;
    p.height = 40;
    p.tf = std::vector<std::uint32_t>(256, rgba8(90, 180, 255, 60));
    p.dt = 0.3f;
    Frame ref = render_dvr_cpu(gw, p, serial);
    p.mode = VolumeMode::BihMulti;
    Frame multi = render_bih_dvr_cpu(VoxelBihView{words, {}, g.spacing, gw.world_box()}, p, serial);
    double worst = 0.0, alpha = 0.0;
    for (std::size_t i = 0; i < ref.rgba.size(); ++i) {
        for (int k = 0; k < 4; ++k) worst = std::max(worst, double(std::abs(ref.rgba[i][k] - multi.rgba[i][k])));
        alpha += ref.rgba[i].a;
    }
    CHECK(worst <= 1e-5);
    CHECK(alpha > 0.2 * double(ref.rgba.size()));
}

TEST_CASE("Iso mode: hit distance on a linear ramp is analytic", "[dvr]") {
    // d(x) = 0.1 + 0.8 (n . x) / (n . box_hi): the iso-surface d = iso is the plane
    // n . x = (iso - 0.1) / 0.8 * (n . box_hi), crossed at t = (c - n . o) / (n . d) along the
    // unit direction. The first point of the chord [c0, c1] reaching iso is c0 when the ray
    // enters at or above iso, else that crossing when it lies inside the chord, else none.
    // The payload quantises density to 1/16383 and gradients to 1/32767, so the density error
    // e <= 0.5/16383 + 3 * 0.5 * 0.5/32767 and |t - t_exact| <= e / |d'(t)|.
    volume::Dims dims{20, 16, 12};
    vec3 spacing{1.0f, 1.0f, 1.5f};
    glm::dvec3 n = glm::normalize(glm::dvec3(0.5, 1.0, 0.4));
    double top = glm::dot(n, glm::dvec3(dims) * glm::dvec3(spacing));
    Field ramp = [=](glm::dvec3 x) { return 0.1 + 0.8 * glm::dot(n, x) / top; };
    volume::DensityGrid g = sample_grid(dims, spacing, ramp);
    for (bih::NodeFormat fmt : {bih::NodeFormat::Float32, bih::NodeFormat::Fixed16}) {
        auto words = encode_voxels(field_cuboids(g, ramp), fmt);
        VolumeRenderParams p;
        p.tf = std::vector<std::uint32_t>(256, rgba8(255, 200, 100, 255));
        p.mode = VolumeMode::BihIso;
        p.iso = 0.45f;
        auto sp = params_of(bih_dvr_params(VoxelBihView{words, {}, spacing, g.world_box()}, p));
        shared::Words bw{words.data(), words.size()}, none{}, tw{p.tf.data(), p.tf.size()};
        double plane = (p.iso - 0.1) / 0.8 * top;
        std::size_t hits = 0, entry_hits = 0;
        for (const Ray& r : rays_into(g.world_box(), 400, 21)) {
            glm::dvec3 o(r.origin), d = glm::normalize(glm::dvec3(r.direction));
            auto c = chord(r, g.world_box());
            double t_exact = (plane - glm::dot(n, o)) / glm::dot(n, d);
            bool enters_above = c && glm::dot(n, o + c->first * d) >= plane;
            bool rises = c && glm::dot(n, d) > 0.0 && t_exact >= c->first && t_exact <= c->second;
            bool expect_hit = enters_above || rises;
            if (enters_above) t_exact = c->first;
            float t_hit;
            std::uint32_t steps, status;
            vec4 s = shared::sylva_bih_iso(bw, none, tw, sp, r.origin, r.direction, 0.0f, shared::sylva_inf(), t_hit, steps,
                                           status);
            double slope = std::abs(0.8 * glm::dot(n, d) / top);
            double tol = (0.5 / 16383 + 0.75 / 32767) / std::max(slope, 1e-12) + 1e-4;
            // Rays that meet the surface within the tolerance of the box boundary may go either way.
            double crossing = (plane - glm::dot(n, o)) / glm::dot(n, d);
            bool near_edge = c && (std::abs(crossing - c->first) < tol || std::abs(crossing - c->second) < tol);
            if (near_edge) continue;
            INFO("t_exact " << t_exact << " t_hit " << t_hit << " tol " << tol);
            REQUIRE(expect_hit == (t_hit < shared::sylva_inf()));
            if (!expect_hit) continue;
            REQUIRE(std::abs(double(t_hit) - t_exact) <= tol);
            REQUIRE(s.a == 1.0f);
            REQUIRE(s.r == Approx(1.0).margin(1e-6));  // unshaded: the TF colour at the iso value
            ++hits;
            entry_hits += enters_above ? 1 : 0;
        }
        CHECK(hits > 100);
        CHECK(entry_hits > 20);         // rays entering the volume above iso hit where they enter
        CHECK(hits - entry_hits > 50);  // the others hit the analytic plane inside
    }
}

TEST_CASE("Iso mode shading: Lambert + Blinn-Phong with the leaf gradient, headlight and a fixed light", "[dvr]") {
    // On the ramp the world gradient is parallel to n everywhere (anisotropic spacing: the
    // per-voxel gradient divided by the spacing), so the shaded colour has a closed form:
    // normal m = -n turned towards the viewer, c * (ka + kd max(m.l, 0)) + ks max(m.h, 0)^s
    // with h the half vector of l and the view direction. Tolerance 2e-3: the 16-bit gradient
    // of a gentle ramp fixes the normal to about 1e-3.
    volume::Dims dims{20, 16, 12};
    vec3 spacing{1.0f, 1.0f, 1.5f};
    glm::dvec3 n = glm::normalize(glm::dvec3(0.5, 1.0, 0.4));
    double top = glm::dot(n, glm::dvec3(dims) * glm::dvec3(spacing));
    Field ramp = [=](glm::dvec3 x) { return 0.1 + 0.8 * glm::dot(n, x) / top; };
    volume::DensityGrid g = sample_grid(dims, spacing, ramp);
    auto words = encode_voxels(field_cuboids(g, ramp), bih::NodeFormat::Float32);
    VolumeRenderParams p;
    p.tf = std::vector<std::uint32_t>(256, rgba8(255, 128, 64, 255));
    p.mode = VolumeMode::BihIso;
    p.iso = 0.5f;
    p.shading = true;
    p.ambient = 0.2f;
    p.diffuse = 0.6f;
    p.specular = 0.3f;
    p.shininess = 8.0f;
    const glm::dvec3 base = glm::dvec3(255, 128, 64) / 255.0;
    shared::Words bw{words.data(), words.size()}, none{}, tw{p.tf.data(), p.tf.size()};
    for (vec3 light : {vec3(0.0f), vec3(0.2f, 0.9f, -0.4f)}) {
        p.light = light;
        auto sp = params_of(bih_dvr_params(VoxelBihView{words, {}, spacing, g.world_box()}, p));
        std::size_t hits = 0;
        for (const Ray& r : rays_into(g.world_box(), 300, 23)) {
            float t_hit;
            std::uint32_t steps, status;
            vec4 s = shared::sylva_bih_iso(bw, none, tw, sp, r.origin, r.direction, 0.0f, shared::sylva_inf(), t_hit, steps,
                                           status);
            if (!(t_hit < shared::sylva_inf())) continue;
            glm::dvec3 view = -glm::normalize(glm::dvec3(r.direction));
            glm::dvec3 m = glm::dot(-n, view) < 0.0 ? n : -n;
            glm::dvec3 l = glm::dot(light, light) > 0.0f ? glm::normalize(glm::dvec3(light)) : view;
            glm::dvec3 h = glm::normalize(l + view);
            double lit = p.ambient + p.diffuse * std::max(glm::dot(m, l), 0.0);
            double spec = p.specular * std::pow(std::max(glm::dot(m, h), 0.0), double(p.shininess));
            for (int k = 0; k < 3; ++k) REQUIRE(s[k] == Approx(std::clamp(base[k] * lit + spec, 0.0, 1.0)).margin(2e-3));
            ++hits;
        }
        CHECK(hits > 100);
    }
}

TEST_CASE("Lattice helpers: first index and positions", "[dvr]") {
    for (float dt : {0.25f, 0.1f, 0.37f, 1.0f / 3.0f}) {
        for (int i = 0; i < 5000; ++i) {
            float t0 = float(i) * 0.0731f;
            std::uint32_t k = shared::sylva_lattice_first(t0, dt);
            REQUIRE(shared::sylva_lattice_t(k, dt) >= t0);
            if (k > 0) REQUIRE(shared::sylva_lattice_t(k - 1, dt) < t0);
        }
    }
    CHECK(shared::sylva_lattice_first(-5.0f, 0.5f) == 0u);
    CHECK(shared::sylva_lattice_first(1.0f, 0.5f) == 2u);
}
