// Host vs Vulkan (lavapipe in CI): exact isosurface images over the implicit kd-tree and the cell
// DDA (shaders/ikd_iso.comp): the same steps, candidate cells and hits per pixel, and colours
// within 1e-6; over float32 grids and over uint8 / uint16 grids read natively; with a constant
// border (the shell cells) too.
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <cmath>

#include <sylva/core/executor.hpp>
#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/vulkan/iso.hpp>

#include "quantised.hpp"

using namespace sylva;

namespace {
/// A device iso frame against a reference: on lavapipe steps, cell and hit counts equal and
/// colours within 1e-6; on a GPU at most devtol::allowed_diverging() pixels with other steps (a
/// ray whose few-ulp difference crosses a cell face or the isovalue elsewhere), the other pixels
/// within devtol's colour tolerance, and the hit counts apart by at most one hit a surface for
/// each pixel allowed to diverge (the cell counts are not compared there: a diverging ray walks
/// other cells).
void check_iso_pair(const vk::Context& ctx, const Frame& ref, const Frame& dev, const IsoCounters& rn,
                    const IsoCounters& dn, std::size_t surfaces) {
    CHECK(rn.hits > 500);
    if (devtol::exact(ctx)) {
        CHECK(ref.steps == dev.steps);
        CHECK(rn.cells == dn.cells);
        CHECK(rn.hits == dn.hits);
        float worst = 0.0f;
        for (std::size_t i = 0; i < ref.rgba.size(); ++i)
            for (int k = 0; k < 4; ++k) worst = std::max(worst, std::fabs(ref.rgba[i][k] - dev.rgba[i][k]));
        CHECK(worst <= 1e-6f);
        return;
    }
    const devtol::FrameDiff d = devtol::compare_frames_on(ref, dev);
    devtol::note(ctx, devtol::describe(ctx, d) + "; hits " + std::to_string(rn.hits) + " / " + std::to_string(dn.hits) +
                          ", cells " + std::to_string(rn.cells) + " / " + std::to_string(dn.cells));
    CHECK(devtol::frames_agree(ctx, d, 1e-6f));
    const auto hit_diff = rn.hits > dn.hits ? rn.hits - dn.hits : dn.hits - rn.hits;
    CHECK(hit_diff <= devtol::allowed_diverging(ctx, d.pixels) * surfaces);
}
}  // namespace

TEST_CASE("parity: isosurface images on the host and on Vulkan, tree and DDA", "[parity]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    struct Case {
        volume::DensityGrid grid;
        std::vector<IsoSurface> isos;
    };
    std::vector<Case> cases;
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {{0.5f, vec4(0.9f, 0.8f, 0.6f, 1.0f)}}});
    cases.push_back({volume::radial_falloff({19, 7, 33}, vec3(9.5f, 3.0f, 16.5f), 15.0f, vec3(1.0f, 2.0f, 0.5f)),
                     {{0.25f, vec4(0.7f, 0.9f, 0.7f, 0.4f)}, {0.5f, vec4(0.9f)}, {0.9f, vec4(1.0f)}}});
    for (Case& c : cases) {
        std::vector<std::uint32_t> words = ikd::encode(ikd::build(c.grid));
        GridWords gw = GridWords::from(c.grid);
        vk::DeviceIso dev(ctx, words, gw);
        for (int run = 0; run < 3; ++run) {
            IsoWalker walker = run == 1 ? IsoWalker::Dda : IsoWalker::Tree;
            IsoRenderParams p;
            if (run == 2) p.border = 0.0f;  // the shell cells a constant border adds (iso_shell.h)
            p.width = 80;
            p.height = 60;
            p.camera = Camera::framing(c.grid.world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(p.width, p.height);
            p.isos = c.isos;
            p.walker = walker;
            IsoCounters hn, dn;
            Frame host = render_iso_cpu(words, gw, p, pool, &hn);
            Frame gpu = dev.render(ctx, p, &dn);
            INFO("walker " << static_cast<int>(walker) << " border " << (p.border ? 1 : 0));
            check_iso_pair(ctx, host, gpu, hn, dn, c.isos.size());
        }
    }
}

TEST_CASE("parity: isosurfaces over uint8 and uint16 grids read natively, host and Vulkan", "[parity][native]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    volume::DensityGrid field = volume::marschner_lobb({37, 30, 41});
    struct Case {
        volume::ScalarType type;
        float lo, hi;
    };
    for (Case c : {Case{volume::ScalarType::U8, 0.0f, 255.0f}, Case{volume::ScalarType::U16, 9000.0f, 51000.0f}}) {
        volume::Volume v = test::quantised(field, c.type, c.lo, c.hi);
        volume::DensityGrid g = volume::normalize(v);
        std::vector<std::uint32_t> words = ikd::encode(ikd::build(g));
        GridWords native = GridWords::native(v), f32 = GridWords::from(g);
        vk::DeviceIso dev(ctx, words, native), dev_f32(ctx, words, f32);
        for (int run = 0; run < 3; ++run) {
            IsoWalker walker = run == 1 ? IsoWalker::Dda : IsoWalker::Tree;
            IsoRenderParams p;
            if (run == 2) p.border = 0.0f;  // the shell cells a constant border adds (iso_shell.h)
            p.width = 72;
            p.height = 56;
            p.camera = Camera::framing(g.world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(p.width, p.height);
            p.isos = {{0.35f, vec4(0.2f, 0.6f, 0.9f, 0.4f)}, {0.6f, vec4(0.9f, 0.8f, 0.6f, 1.0f)}};
            p.walker = walker;
            IsoCounters hn, dn, fn;
            Frame host = render_iso_cpu(words, native, p, pool, &hn);
            Frame gpu = dev.render(ctx, p, &dn);
            Frame gpu_f32 = dev_f32.render(ctx, p, &fn);
            check_iso_pair(ctx, host, gpu, hn, dn, p.isos.size());
            CHECK(dn.errors == 0);
            // The device reads the same densities from either grid: identical pixels (on a GPU,
            // whose division need not be exact, within devtol's limits).
            if (devtol::exact(ctx)) {
                CHECK(gpu.steps == gpu_f32.steps);
                CHECK(dn.hits == fn.hits);
                CHECK(gpu.rgba == gpu_f32.rgba);
            } else {
                check_iso_pair(ctx, gpu_f32, gpu, fn, dn, p.isos.size());
            }
        }
    }
}
