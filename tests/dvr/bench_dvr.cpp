// sylva_dvr_bench: host (and Vulkan) rays/s of the reference marcher against single-sample
// BIH-DVR on a real volume (default engine_256x256x128_uint8.raw, voxels >= 0.1 as BIH
// elements, Kinkelin 6.2.1). A measurement, not a test: one run is noisy.
//
//   sylva_dvr_bench [volume.raw X Y Z] [--size N] [--png DIR]
//
// TF: transparent up to density 0.1, alpha rising linearly to 0.2 at density 1 (opacity per
// voxel length, unit = 1), colour from blue (0.28, 0.3, 0.85) to (1, 0.8, 0.3); headlight
// shading off; dt = 256 / 1024; alpha_stop 0.99.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include <sylva/render/metrics.hpp>
#if SYLVA_HAVE_OIIO
#include <sylva/render/image.hpp>
#endif
#if SYLVA_DVR_BENCH_VULKAN
#include <sylva/vulkan/volume.hpp>
#endif

#include "dvr_fixtures.hpp"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

volume::DensityGrid read_u8(const std::string& path, volume::Dims dims) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error("cannot open " + path);
    std::vector<unsigned char> raw(volume::voxel_count(dims));
    in.read(reinterpret_cast<char*>(raw.data()), std::streamsize(raw.size()));
    if (std::size_t(in.gcount()) != raw.size()) throw Error(path + ": fewer bytes than the dimensions say");
    volume::DensityGrid g{dims, vec3(1.0f), std::vector<float>(raw.size())};
    for (std::size_t i = 0; i < raw.size(); ++i) g.values[i] = float(raw[i]) / 255.0f;
    return g;
}

void report(const char* what, const Frame& f, double ms) {
    std::uint64_t steps = 0;
    for (std::uint32_t s : f.steps) steps += s;
    double rays = double(f.width) * f.height;
    std::printf("%-34s %9.1f ms  %9.0f rays/s  mean steps %.1f\n", what, ms, rays / (ms * 1e-3), double(steps) / rays);
}

void save(const std::string& dir, const std::string& name, const Frame& f) {
#if SYLVA_HAVE_OIIO
    if (!dir.empty()) {
        write_frame(dir + "/" + name + ".png", f);
        write_heatmap(dir + "/" + name + "_steps.png", f);
    }
#else
    (void)dir, (void)name, (void)f;
#endif
}

}  // namespace

int main(int argc, char** argv) try {
    std::string path = std::string(SYLVA_DATA_DIR) + "/engine_256x256x128_uint8.raw", png;
    volume::Dims dims{256, 256, 128};
    std::uint32_t size = 256;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--size" && i + 1 < argc) size = std::uint32_t(std::stoul(argv[++i]));
        else if (a == "--png" && i + 1 < argc) png = argv[++i];
        else if (i + 3 < argc) {
            path = a;
            dims = {std::stoul(argv[i + 1]), std::stoul(argv[i + 2]), std::stoul(argv[i + 3])};
            i += 3;
        }
    }
    ThreadPool pool;
    volume::DensityGrid grid = read_u8(path, dims);
    GridWords gw = GridWords::from(grid);
    auto cuboids = grid_cuboids(grid, 0.1f);
    auto t0 = std::chrono::steady_clock::now();
    std::span<const VoxelCuboid> es(cuboids);
    bih::Tree tree = bih::build(es, {}, pool);
    auto words = bih::encode(tree, es, VoxelPayload{}, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2});
    double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%s: %zu elements (>= 0.1), %zu nodes, depth %u, %.1f MiB, build+encode %.0f ms, %zu threads\n",
                path.c_str(), cuboids.size(), tree.nodes.size(), tree.stats.max_depth, double(words.size()) * 4 / 1048576.0,
                build_ms, pool.concurrency());

    VolumeRenderParams p;
    p.camera = Camera::framing(grid.world_box(), {0.4f, 0.3f, 1.0f}, 30.0f).frame(size, size);
    p.width = p.height = size;
    p.tf = make_tf(256, [](float d) {
        float a = d <= 0.1f ? 0.0f : 0.2f * (d - 0.1f) / 0.9f;
        return vec4(0.2f + 0.8f * d, 0.3f + 0.5f * d, 0.95f - 0.65f * d, a);
    });
    VoxelBihView view{words, {}, grid.spacing, grid.world_box()};
    Frame ref = render_dvr_cpu(gw, p, pool);
    report("host marcher", ref, ref.ms);
    p.mode = VolumeMode::BihSingle;
    Frame single = render_bih_dvr_cpu(view, p, pool);
    report("host single-sample BIH-DVR", single, single.ms);
    p.mode = VolumeMode::BihMulti;
    Frame multi = render_bih_dvr_cpu(view, p, pool);
    report("host multi-sample BIH-DVR", multi, multi.ms);
    std::printf("PSNR vs marcher over black: single %.2f dB (max %.3f), multi %.2f dB (max %.3f)\n",
                psnr(ref, single), max_abs_diff(ref, single), psnr(ref, multi), max_abs_diff(ref, multi));
    save(png, "marcher", ref);
    save(png, "single", single);
    save(png, "multi", multi);
    p.shading = true;
    p.mode = VolumeMode::DvrReference;
    Frame shaded = render_dvr_cpu(gw, p, pool);
    report("host marcher, shaded", shaded, shaded.ms);
    save(png, "marcher_shaded", shaded);
    p.mode = VolumeMode::BihSingle;
    Frame single_shaded = render_bih_dvr_cpu(view, p, pool);
    report("host single-sample, shaded", single_shaded, single_shaded.ms);
    save(png, "single_shaded", single_shaded);
    std::printf("PSNR shaded: single vs marcher %.2f dB\n", psnr(shaded, single_shaded));
    auto ranges = NodeRanges(words, grid.spacing).words();
    VoxelBihView culled_view{words, ranges, grid.spacing, grid.world_box()};
    p.mode = VolumeMode::BihIso;
    p.iso = 0.3f;
    Frame iso = render_bih_dvr_cpu(culled_view, p, pool);
    report("host iso 0.3", iso, iso.ms);
    p.iso_culling = true;
    Frame iso_culled = render_bih_dvr_cpu(culled_view, p, pool);
    report("host iso 0.3, node-range culling", iso_culled, iso_culled.ms);
    std::printf("iso culling: identical image %s\n", iso.rgba == iso_culled.rgba ? "yes" : "NO");
    save(png, "iso", iso);
    p.iso_culling = false;
    p.shading = false;
#if SYLVA_DVR_BENCH_VULKAN
    vk::Context ctx = vk::Context::create();
    vk::DeviceGrid dgrid(ctx, gw);
    vk::DeviceVoxelBih dbih(ctx, view);
    std::printf("[%s] (first frame includes the pipeline's compilation)\n", ctx.describe().c_str());
    p.mode = VolumeMode::DvrReference;
    Frame vref = vk::render_dvr_vulkan(ctx, dgrid, p);
    report("vulkan marcher, first frame", vref, vref.ms);
    vref = vk::render_dvr_vulkan(ctx, dgrid, p);
    report("vulkan marcher", vref, vref.ms);
    p.mode = VolumeMode::BihSingle;
    Frame vsingle = vk::render_bih_dvr_vulkan(ctx, dbih, p);
    report("vulkan single-sample, first frame", vsingle, vsingle.ms);
    vsingle = vk::render_bih_dvr_vulkan(ctx, dbih, p);
    report("vulkan single-sample BIH-DVR", vsingle, vsingle.ms);
    p.mode = VolumeMode::BihMulti;
    Frame vmulti = vk::render_bih_dvr_vulkan(ctx, dbih, p);
    vmulti = vk::render_bih_dvr_vulkan(ctx, dbih, p);
    report("vulkan multi-sample BIH-DVR", vmulti, vmulti.ms);
    std::printf("vulkan vs host: marcher max diff %.2e, single max diff %.2e\n", max_abs_diff(ref, vref),
                max_abs_diff(single, vsingle));
#endif
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "sylva_dvr_bench: %s\n", e.what());
    return 1;
}
