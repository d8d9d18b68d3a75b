// The caller's rays (sylva/render/rays.hpp, sylva/shared/rays.h) on the host: the orthographic
// generator against an analytic slab, and a ray buffer or callable equal to a camera's rays
// giving that camera's image bit for bit through every volume renderer (marcher, BIH-DVR,
// kd-tree ESS, octree, implicit-kd isosurfaces).
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstring>

#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/rays.hpp>

#include "dvr_fixtures.hpp"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

/// Pixels whose RGBA bits or steps differ.
std::size_t differing_bits(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        n += (std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0 || a.steps[i] != b.steps[i]) ? 1 : 0;
    return n;
}

double summed_alpha(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.a;
    return s;
}

/// The same frame's rays as a buffer (6 floats a pixel), written here independently of
/// ray_buffer(): the pinhole or orthographic formula of sylva/shared/camera.h in float.
std::vector<float> camera_rays(const CameraFrame& c, RaySource s, std::uint32_t w, std::uint32_t h) {
    std::vector<float> out;
    for (std::uint32_t y = 0; y < h; ++y)
        for (std::uint32_t x = 0; x < w; ++x) {
            float sx = (float(x) + 0.5f) / float(w) * 2.0f - 1.0f;
            float sy = 1.0f - (float(y) + 0.5f) / float(h) * 2.0f;
            vec3 o = c.eye, d = c.w;
            vec3 off(sx * c.u.x + sy * c.v.x, sx * c.u.y + sy * c.v.y, sx * c.u.z + sy * c.v.z);
            if (s == RaySource::Ortho) {
                o = vec3(c.eye.x + sx * c.u.x + sy * c.v.x, c.eye.y + sx * c.u.y + sy * c.v.y,
                         c.eye.z + sx * c.u.z + sy * c.v.z);
            } else {
                d = vec3(c.w.x + sx * c.u.x + sy * c.v.x, c.w.y + sx * c.u.y + sy * c.v.y, c.w.z + sx * c.u.z + sy * c.v.z);
            }
            (void)off;
            out.insert(out.end(), {o.x, o.y, o.z, d.x, d.y, d.z});
        }
    return out;
}

}  // namespace

TEST_CASE("Orthographic rays: a constant slab seen along an axis has the lattice opacity in its footprint",
          "[dvr][rays]") {
    // 16 x 8 x 4 voxels of density 0.5, constant TF alpha a. Orthographic rays along -z from
    // z = 10 start on a 40 x 30 pixel view rectangle of half extents 10 x 7.5 around (8, 6):
    // pixel centres at x = -2 + (i + 0.5) 0.5, y = 13.5 - (j + 0.5) 0.5, never on the box's
    // faces. Inside the footprint [0, 16] x [0, 12] every ray crosses z in [0, 3]: lattice
    // samples t_k = k dt in [7, 10); outside it nothing. A pinhole camera would give a
    // perspective footprint and varying chords.
    volume::DensityGrid g = sample_grid({16, 8, 4}, {1.0f, 1.5f, 0.75f}, [](glm::dvec3) { return 0.5; });
    GridWords gw = GridWords::from(g);
    const double a = 77.0 / 255.0, unit = 2.0;
    VolumeRenderParams p;
    p.width = 40;
    p.height = 30;
    p.tf = std::vector<std::uint32_t>(256, rgba8(200, 100, 50, 77));
    p.unit = float(unit);
    p.alpha_stop = 2.0f;
    p.camera = CameraFrame{vec3(8.0f, 6.0f, 10.0f), vec3(0.0f, 0.0f, -1.0f), vec3(10.0f, 0.0f, 0.0f), vec3(0.0f, 7.5f, 0.0f)};
    p.rays.source = RaySource::Ortho;
    ThreadPool pool(2);
    Frame f = render_dvr_cpu(gw, p, pool);
    float dt = default_dt(gw.world_box());
    std::size_t n = 0;  // lattice samples with 7 <= k dt < 10, in float as the lattice is
    for (std::uint32_t k = 0; float(k) * dt < 10.0f; ++k) n += float(k) * dt >= 7.0f ? 1 : 0;
    const double expect = 1.0 - std::pow(1.0 - a, double(n) * dt / unit);
    std::size_t inside = 0;
    for (std::uint32_t j = 0; j < p.height; ++j)
        for (std::uint32_t i = 0; i < p.width; ++i) {
            double x = -2.0 + (i + 0.5) * 0.5, y = 13.5 - (j + 0.5) * 0.5;
            bool in = x > 0.0 && x < 16.0 && y > 0.0 && y < 12.0;
            const vec4& c = f.rgba[j * p.width + i];
            INFO("pixel " << i << "," << j << " at " << x << "," << y);
            if (in) {
                ++inside;
                REQUIRE(f.steps[j * p.width + i] == n);
                REQUIRE(c.a == Approx(expect).margin(2e-6));
                REQUIRE(c.r == Approx(200.0 / 255.0 * expect).margin(2e-6));
            } else {
                REQUIRE(f.steps[j * p.width + i] == 0u);
                REQUIRE(c.a == 0.0f);
            }
        }
    CHECK(inside == 32u * 24u);
}

TEST_CASE("Ray buffers and callables equal to a camera give that camera's image bit for bit", "[dvr][rays]") {
    ThreadPool pool(2);
    volume::Dims dims{24, 20, 18};
    vec3 spacing{1.0f, 1.1f, 1.2f};
    volume::DensityGrid grid = sample_grid(dims, spacing, blobs(vec3(dims) * spacing));
    GridWords gw = GridWords::from(grid);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    VoxelBihView view{bih, {}, spacing, grid.world_box()};
    const std::uint32_t W = 40, H = 32;
    Camera cam = Camera::framing(grid.world_box(), vec3(0.5f, 0.35f, 1.0f), 36.0f);
    std::vector<std::uint32_t> tf = smooth_tf(0.08f, 0.3f);
    std::vector<std::uint32_t> kd = kdtree::encode(kdtree::build_vidal(
        ess_occupancy(ess_codes(grid, static_cast<std::uint32_t>(tf.size()), pool), ess_classifier(tf), pool),
        kdtree::Config::deep()));
    octree::Tree oct = octree::build(grid, pool, {8, 2});
    std::vector<std::uint32_t> oct_words = octree::encode(oct);
    std::vector<std::uint32_t> ikd_words = ikd::encode(ikd::build(grid));

    for (RaySource source : {RaySource::Pinhole, RaySource::Ortho}) {
        VolumeRenderParams p;
        p.width = W;
        p.height = H;
        p.camera = source == RaySource::Ortho ? cam.ortho_frame(W, H, 0.5f * glm::length(grid.world_box().extent()))
                                              : cam.frame(W, H);
        p.rays.source = source;
        p.tf = tf;
        p.light = vec3(0.2f, 1.0f, 0.4f);
        p.shading = true;
        std::vector<float> buf = camera_rays(p.camera, source, W, H);
        REQUIRE(ray_buffer(p.camera, p.rays, W, H) == buf);  // the generator, float for float
        VolumeRenderParams pb = p, pf = p;
        pb.rays = PixelRays::from_buffer(buf);
        pf.rays = PixelRays::from_function([&](std::uint32_t x, std::uint32_t y) {
            const float* r = &buf[(std::size_t{y} * W + x) * 6];
            return Ray{vec3(r[0], r[1], r[2]), vec3(r[3], r[4], r[5])};
        });
        INFO("source " << static_cast<int>(source));
        auto same = [&](auto render) {
            Frame a = render(p), b = render(pb), c = render(pf);
            CHECK(summed_alpha(a) > 10.0);
            CHECK(differing_bits(a, b) == 0);
            CHECK(differing_bits(a, c) == 0);
        };
        same([&](const VolumeRenderParams& q) { return render_dvr_cpu(gw, q, pool); });
        for (VolumeMode m : {VolumeMode::BihSingle, VolumeMode::BihMulti, VolumeMode::BihIso}) {
            same([&](const VolumeRenderParams& q) {
                VolumeRenderParams r = q;
                r.mode = m;
                return render_bih_dvr_cpu(view, r, pool);
            });
        }
        same([&](const VolumeRenderParams& q) { return render_kd_dvr_cpu(gw, kd, q, pool); });
        same([&](const VolumeRenderParams& q) { return render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, q, pool); });

        IsoRenderParams ip;
        ip.width = W;
        ip.height = H;
        ip.camera = p.camera;
        ip.rays.source = source;
        IsoRenderParams ib = ip;
        ib.rays = PixelRays::from_buffer(buf);
        Frame ia = render_iso_cpu(ikd_words, gw, ip, pool), ibf = render_iso_cpu(ikd_words, gw, ib, pool);
        Frame ipk = render_iso_cpu_packets(ikd_words, gw, ib, pool);
        CHECK(summed_alpha(ia) > 10.0);
        CHECK(differing_bits(ia, ibf) == 0);
        std::size_t colour_diff = 0;  // packets count packet steps, colours are the same
        for (std::size_t i = 0; i < ia.rgba.size(); ++i)
            colour_diff += std::memcmp(&ia.rgba[i], &ipk.rgba[i], sizeof(vec4)) != 0 ? 1 : 0;
        CHECK(colour_diff == 0);
    }
}

TEST_CASE("Orthographic and pinhole images differ, and bad ray buffers are refused", "[dvr][rays]") {
    ThreadPool pool(2);
    volume::DensityGrid grid = sample_grid({16, 16, 16}, vec3(1.0f), blobs(vec3(16.0f)));
    GridWords gw = GridWords::from(grid);
    VolumeRenderParams p;
    p.width = p.height = 24;
    p.tf = smooth_tf(0.08f, 0.3f);
    Camera cam = Camera::framing(grid.world_box());
    p.camera = cam.ortho_frame(24, 24, 14.0f);
    p.rays.source = RaySource::Ortho;
    Frame ortho = render_dvr_cpu(gw, p, pool);
    p.camera = cam.frame(24, 24);
    p.rays.source = RaySource::Pinhole;
    Frame pin = render_dvr_cpu(gw, p, pool);
    CHECK(differing_bits(ortho, pin) > 100);

    p.rays = PixelRays::from_buffer(std::vector<float>(24 * 24 * 6 - 1, 1.0f));
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("ray buffer holds 3455 floats"));
    std::vector<float> nan(24 * 24 * 6, 1.0f);
    nan[100] = std::nanf("");
    p.rays = PixelRays::from_buffer(nan);
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("ray buffer float 100 (pixel 16) is not finite"));
    p.rays = PixelRays{static_cast<RaySource>(7), {}, {}};
    CHECK_THROWS_WITH(render_dvr_cpu(gw, p, pool), Catch::Contains("unknown ray source 7"));
}
