// The library's particle kernel over the element octree (shaders/octree_particles.comp through
// sylva/vulkan/octree_particles.hpp) against the host renderer (sylva/render/octree_particles.hpp)
// on the same encoding, records and camera: per pixel the same step count and error mark
// exactly, and colours within 1e-5 (exp() and division may differ by a few ulp between the
// host's libm and the device: docs/DESIGN.md, What is exact where). Spheres, RBFs, the synthetic galaxy
// and the dark-matter halo of ../shared/data; split bindings; corrupted encodings.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/elements/rbf.hpp>
#include <sylva/io/particles.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/elements.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/render/particles.hpp>
#include <sylva/render/octree_particles.hpp>
#include <sylva/spirv/elements_sphere.h>
#include <sylva/spirv/elements_sphere_octree.h>
#include <sylva/vulkan/bih.hpp>
#include <sylva/vulkan/elements.hpp>
#include <sylva/vulkan/loop_limit.hpp>
#include <sylva/vulkan/octree_particles.hpp>

#include "../device_tolerance.hpp"
#include "../missing_data.hpp"
#include "common.hpp"

using namespace sylva;
using namespace octe_test;

namespace {

constexpr std::uint32_t kW = 96, kH = 72;

/// How a device frame differs from the host's: pixels whose steps or error mark differ, and
/// the largest channel difference (premultiplied RGB and alpha).
struct FrameParity {
    std::size_t step_mismatches = 0;
    std::size_t errors = 0;       ///< host pixels marked 0xFFFFFFFF
    std::size_t device_only = 0;  ///< device pixels marked 0xFFFFFFFF where the host rendered
    std::size_t lit = 0;     ///< host pixels with alpha > 0.05
    std::size_t bit_identical = 0;
    float worst = 0.0f;
    float worst_same_steps = 0.0f;  ///< over the pixels whose steps agree
    /// The largest difference this device answers for: every pixel on lavapipe; on a GPU the
    /// pixels whose path did not flip (devtol), the others being counted in step_mismatches.
    float worst_on(const vk::Context& ctx) const { return devtol::exact(ctx) ? worst : worst_same_steps; }
    bool steps_ok(const vk::Context& ctx, std::size_t pixels) const {
        return step_mismatches <= devtol::allowed_diverging(ctx, pixels);
    }
};

/// With `device_may_stop`, a device error mark where the host rendered is counted in
/// device_only instead of as a mismatch (a corrupted reference list can make a ray run past
/// lavapipe's loop limiter, which the kernel reports as an error), and that pixel's colour is
/// not compared.
FrameParity compare(const Frame& host, const Frame& dev, bool device_may_stop = false) {
    FrameParity p;
    REQUIRE(host.rgba.size() == dev.rgba.size());
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        if (device_may_stop && dev.steps[i] == 0xFFFFFFFFu && host.steps[i] != 0xFFFFFFFFu) {
            ++p.device_only;
            continue;
        }
        if (host.steps[i] != dev.steps[i] && p.step_mismatches++ < 3)
            UNSCOPED_INFO("pixel " << i << ": host steps " << host.steps[i] << ", device " << dev.steps[i]);
        p.errors += host.steps[i] == 0xFFFFFFFFu;
        p.lit += host.rgba[i].a > 0.05f;
        p.bit_identical += host.rgba[i] == dev.rgba[i];
        for (int c = 0; c < 4; ++c) {
            const float d = std::abs(host.rgba[i][c] - dev.rgba[i][c]);
            p.worst = std::max(p.worst, d);
            if (host.steps[i] == dev.steps[i]) p.worst_same_steps = std::max(p.worst_same_steps, d);
        }
    }
    return p;
}

std::vector<std::uint32_t> identity(std::size_t n) {
    std::vector<std::uint32_t> id(n);
    std::iota(id.begin(), id.end(), 0u);
    return id;
}

/// Builds and encodes `elems` (Particle elements), renders them on both sides at two
/// alpha_stop values, checks parity and returns the host frames' lit pixels.
template <class E>
std::size_t check_images(vk::Context& ctx, const std::vector<E>& elems, const char* name, std::uint32_t shift = 0) {
    std::span<const E> s(elems);
    ThreadPool pool(2);
    auto words = octree::encode_elements(octree::build_elements(s, {}, pool));
    auto records = pack_particles(s, std::span<const std::uint32_t>(identity(elems.size())));
    vk::DeviceElementOctree oct(ctx, words, records, shift);
    CameraFrame cam = Camera::framing(scene_of(elems)).frame(kW, kH);
    std::size_t lit = 0;
    for (float stop : {0.99f, 2.0f}) {
        ParticleRenderConfig rc;
        rc.alpha_stop = stop;
        Frame host = render_particles_octree_cpu(words, records, cam, kW, kH, pool, rc);
        Frame dev = vk::render_particles_octree_vulkan(ctx, oct, cam, kW, kH, rc);
        FrameParity p = compare(host, dev);
        INFO(name << ", alpha_stop " << stop << ": " << p.step_mismatches << " step mismatches, worst channel "
                  << p.worst << ", " << p.bit_identical << " of " << host.rgba.size() << " pixels bit-identical, PSNR "
                  << psnr(host, dev) << " dB");
        devtol::note(ctx, std::string(name) + ": " + std::to_string(p.step_mismatches) + " of " +
                              std::to_string(host.rgba.size()) + " pixels with other steps, worst channel " +
                              std::to_string(p.worst) + ", " + std::to_string(p.worst_same_steps) + " where the steps agree");
        CHECK(p.steps_ok(ctx, host.rgba.size()));
        CHECK(p.errors == 0);
        CHECK(p.worst_on(ctx) <= devtol::colour_tolerance(ctx, 1e-5f));
        CHECK(p.lit > host.rgba.size() / 100);
        lit += p.lit;
    }
    return lit;
}

}  // namespace

TEST_CASE("vulkan: element octree particle images equal the host's (spheres, RBFs, galaxy)", "[parity][images]") {
    vk::Context ctx = vk::Context::create();
    check_images(ctx, testing::random_spheres(3000, 201), "uniform spheres");
    check_images(ctx, clustered_spheres(4000, 202), "clustered spheres");
    std::vector<GaussianRbf> rbfs;
    for (const Sphere& p : testing::random_spheres(5000, 203)) rbfs.push_back({p.center, p.radius / 3.0f, 3.0f, p.rgba});
    check_images(ctx, rbfs, "RBFs");
    check_images(ctx, io::synthetic_galaxy(20000), "galaxy");
}

TEST_CASE("vulkan: element octree particle images with the index and records split over several bindings",
          "[parity][images]") {
    vk::Context ctx = vk::Context::create();
    auto ps = testing::random_spheres(2000, 204);
    // 2^14 words a part: the index (about 1e5 words) and the records (16000 words) both span parts.
    check_images(ctx, ps, "spheres, parts of 2^14 words", 14);
}

TEST_CASE("vulkan: element octree particle image of the dark-matter halo equals the host's", "[parity][images][data]") {
    vk::Context ctx = vk::Context::create();
    auto path = testdata::require("dark_matter_halo_32314x3_float32.raw");
    check_images(ctx, io::spheres_from_points(io::read_points(path.string())), "halo");
}

TEST_CASE("vulkan: corrupted element octrees stop with an error mark on the same pixels as the host",
          "[parity][images][errors]") {
    vk::Context ctx = vk::Context::create();
    auto ps = testing::random_spheres(600, 205);
    std::span<const Sphere> s(ps);
    ThreadPool pool(2);
    octree::ElementTree et = octree::build_elements(s);
    const auto good = octree::encode_elements(et);
    auto records = pack_particles(s, std::span<const std::uint32_t>(identity(ps.size())));
    CameraFrame cam = Camera::framing(scene_of(ps)).frame(48, 36);
    std::size_t device_only = 0;
    auto run = [&](const std::vector<std::uint32_t>& w, const std::string& what) {
        INFO(what);
        vk::DeviceElementOctree oct(ctx, w, records);
        Frame host = render_particles_octree_cpu(w, records, cam, 48, 36, pool);
        Frame dev = vk::render_particles_octree_vulkan(ctx, oct, cam, 48, 36);
        FrameParity p = compare(host, dev, true);
        CHECK(p.steps_ok(ctx, host.rgba.size()));
        CHECK(p.worst_on(ctx) <= devtol::colour_tolerance(ctx, 1e-5f));
        device_only += p.device_only;
        return p.errors;
    };
    REQUIRE(run(good, "intact") == 0);
    REQUIRE(device_only == 0);
    // Targeted corruptions, each of which must stop some rays with an error.
    std::uint32_t refs = SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * good[6];
    std::vector<std::pair<std::string, std::vector<std::uint32_t>>> cases;
    {
        auto w = good;  // the first reference list's count runs past the index
        w[refs] = 0xFFFFFFF0u;
        cases.push_back({"reference count past the index", w});
    }
    {
        auto w = good;  // the first reference list's count 0
        w[refs] = 0u;
        cases.push_back({"reference count 0", w});
    }
    {
        auto w = good;  // every element index past the element count
        for (std::size_t i = refs; i < w.size(); ++i) w[i] = std::max(w[i], 0x7FFFFFFFu);
        cases.push_back({"element indices past the element count", w});
    }
    {
        auto w = good;  // every leaf's list pointer past the index
        for (std::uint32_t n = 0; n < good[6]; ++n) {
            std::uint32_t& at = w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n + 12];
            if (at != SYLVA_OCT_NONE) at = std::uint32_t(w.size()) + 5u;
        }
        cases.push_back({"reference lists past the index", w});
    }
    {
        auto w = good;  // header: total word count
        w[9] ^= 1u;
        cases.push_back({"header word count", w});
    }
    for (const auto& [what, w] : cases) CHECK(run(w, what) > 0);
    // Random bit flips anywhere: the same marks and colours on both sides, never a hang.
    std::mt19937 rng(206);
    std::size_t errors = 0;
    for (int trial = 0; trial < 30; ++trial) {
        auto w = good;
        std::ostringstream flips;
        for (int k = 0; k < 4; ++k) {
            std::size_t at = rng() % w.size();
            std::uint32_t bit = rng() % 32;
            w[at] ^= 1u << bit;
            flips << " word " << at << " bit " << bit;
        }
        errors += run(w, "random flips:" + flips.str());
    }
    CHECK(errors > 0);
    WARN("corrupted encodings: " << errors << " pixels stopped with an error on both sides, " << device_only
                                 << " on the device only (its loop limiter)");
}

TEST_CASE("vulkan: a leaf too long for lavapipe's loop limiter is marked an error, never drawn short",
          "[parity][images][errors]") {
    // 3000 coincident particles and a few others: the coincident ones share one leaf at the
    // depth limit, and a ray through it composites all 3000 in ceil(3000 / 32) passes over 3000
    // references, past the 65535 loop iterations lavapipe allows an invocation. The device
    // must mark those rays, and equal the host on every other pixel.
    std::vector<Sphere> ps(3000, Sphere{vec3(0.5f), 0.05f, vec4(0.9f, 0.5f, 0.2f, 0.01f), 2.0f});
    for (const Sphere& p : testing::random_spheres(500, 207)) ps.push_back(p);
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    std::span<const Sphere> s(ps);
    auto words = octree::encode_elements(octree::build_elements(s, {}, pool));
    auto records = pack_particles(s, std::span<const std::uint32_t>(identity(ps.size())));
    vk::DeviceElementOctree oct(ctx, words, records);
    CameraFrame cam = Camera::framing(scene_of(ps)).frame(48, 36);
    ParticleRenderConfig rc;
    rc.alpha_stop = 2.0f;  // no early termination: every ray through the cluster takes all 3000
    Frame host = render_particles_octree_cpu(words, records, cam, 48, 36, pool, rc);
    Frame dev = vk::render_particles_octree_vulkan(ctx, oct, cam, 48, 36, rc);
    FrameParity p = compare(host, dev, true);
    CHECK(p.errors == 0);  // the host draws everything
    CHECK(p.steps_ok(ctx, host.rgba.size()));
    CHECK(p.worst_on(ctx) <= devtol::colour_tolerance(ctx, 1e-5f));
    if (vk::loops_limited(ctx)) {
        CHECK(p.device_only > 0);  // the cluster's pixels: marked, not drawn short
    } else {
        CHECK(p.device_only == 0);  // no loop limiter (a GPU, lavapipe 25): every pixel drawn
    }
    WARN("coincident cluster: " << p.device_only << " of " << host.rgba.size()
                                << " pixels marked on the device only (loop limiter); the others equal the host");
}

TEST_CASE("vulkan: the particle kernels take the caller's rays: orthographic and a ray buffer", "[parity][images][rays]") {
    // The element octree's kernel, the BIH's particle kernel and the generic element kernel (over
    // the BIH and the element octree), each with an orthographic camera and with a buffer of those
    // rays, against the host's renderer with the same rays: steps equal, colours within 1e-5; on
    // the device the buffer gives the generator's image bit for bit.
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    auto ps = testing::random_spheres(3000, 206);
    std::span<const Sphere> s(ps);
    Aabb box = scene_of(ps);
    CameraFrame cam = Camera::framing(box, {0.3f, 0.6f, 1.0f}).ortho_frame(kW, kH, 0.5f * glm::length(box.extent()));
    auto rec = pack_particles(s, std::span<const std::uint32_t>(identity(ps.size())));
    auto ow = octree::encode_elements(octree::build_elements(s, {}, pool));
    bih::Tree bt = bih::build(s, {}, pool);
    auto bw = bih::encode(bt, s, bih::RangePayload{});
    auto brec = pack_particles(s, std::span<const std::uint32_t>(bt.order));
    vk::DeviceElementOctree oct(ctx, ow, rec);
    vk::DeviceBih dbih(ctx, bw);
    vk::DeviceElementIndex doct_index(ctx, ow);
    vk::DeviceRecords drec(ctx, rec, element_words<Sphere>()), dbrec(ctx, brec, element_words<Sphere>());
    vk::ElementKernel bih_kernel(ctx, spirv::elements_sphere), oct_kernel(ctx, spirv::elements_sphere_octree);
    ParticleRenderConfig ortho;
    ortho.rays.source = RaySource::Ortho;
    ParticleRenderConfig buffer = ortho;
    buffer.rays = PixelRays::from_buffer(ray_buffer(cam, ortho.rays, kW, kH));
    std::size_t lit = 0;
    for (const ParticleRenderConfig* rc : {&ortho, &buffer}) {
        struct Pair {
            const char* name;
            Frame host, dev;
        };
        std::vector<Pair> pairs;
        pairs.push_back({"element octree kernel", render_particles_octree_cpu(ow, rec, cam, kW, kH, pool, *rc),
                         vk::render_particles_octree_vulkan(ctx, oct, cam, kW, kH, *rc)});
        pairs.push_back({"BIH particle kernel", render_particles_cpu(bw, brec, cam, kW, kH, pool, *rc),
                         vk::render_particles_vulkan(ctx, dbih, brec, cam, kW, kH, *rc)});
        pairs.push_back({"element kernel, BIH", render_elements_cpu<Sphere, BihIndex>(bw, brec, cam, kW, kH, pool, *rc),
                         bih_kernel.render(dbih, dbrec, cam, kW, kH, *rc)});
        pairs.push_back({"element kernel, octree", render_elements_cpu<Sphere, OctreeIndex>(ow, rec, cam, kW, kH, pool, *rc),
                         oct_kernel.render(doct_index, drec, cam, kW, kH, *rc)});
        for (const Pair& q : pairs) {
            FrameParity p = compare(q.host, q.dev);
            INFO(q.name << (rc == &buffer ? ", ray buffer" : ", orthographic") << ": worst channel " << p.worst);
            devtol::note(ctx, std::string(q.name) + ": " + std::to_string(p.step_mismatches) + " pixels with other steps, worst " +
                                  std::to_string(p.worst) + ", " + std::to_string(p.worst_same_steps) + " where the steps agree");
            CHECK(p.steps_ok(ctx, q.host.rgba.size()));
            CHECK(p.errors == 0);
            CHECK(p.worst_on(ctx) <= devtol::colour_tolerance(ctx, 1e-5f));
            lit += p.lit;
        }
    }
    CHECK(lit > 8 * std::size_t{kW} * kH / 10);  // each of the 8 images shows the spheres
    // Device: the buffer of the orthographic rays gives the generator's image bit for bit (on a
    // GPU the generator's rays are the host's within a few ulp: devtol's limits).
    const Frame from_buffer = vk::render_particles_octree_vulkan(ctx, oct, cam, kW, kH, buffer);
    const Frame generated = vk::render_particles_octree_vulkan(ctx, oct, cam, kW, kH, ortho);
    if (devtol::exact(ctx)) {
        CHECK(from_buffer.rgba == generated.rgba);
    } else {
        FrameParity p = compare(from_buffer, generated);
        CHECK(p.steps_ok(ctx, generated.rgba.size()));
        CHECK(p.worst_on(ctx) <= devtol::kGpuColourAbs);
    }
    ParticleRenderConfig short_buffer = buffer;
    short_buffer.rays.buffer.resize(6);
    CHECK_THROWS_WITH(vk::render_particles_octree_vulkan(ctx, oct, cam, kW, kH, short_buffer), Catch::Contains("ray buffer"));
    CHECK_THROWS_WITH(bih_kernel.render(dbih, dbrec, cam, kW, kH, short_buffer), Catch::Contains("ray buffer"));
}
