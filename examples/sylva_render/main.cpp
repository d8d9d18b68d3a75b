// sylva-render: builds a BIH (or, with --index octree, the element octree: particle_octree_scene.hpp)
// over particles (a file or a procedural galaxy) or over the voxels of a volume (a file or a
// procedural volume; see volume_scene.cpp), renders it on the host or through Vulkan, writes the
// image, an optional traversal-cost heat map and statistics.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <new>
#include <stdexcept>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/core/progress.hpp>
#include <sylva/io/particles.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/particles.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/bih.hpp>
#endif

#include "options.hpp"
#include "animation_scene.hpp"
#include "exact_particles_scene.hpp"
#include "kd_particles_scene.hpp"
#include "particle_octree_scene.hpp"
#include "particle_view.hpp"
#include "stats.hpp"
#include "volume_scene.hpp"

using namespace sylva;

namespace sylva_render {
namespace {

std::vector<Sphere> load_scene(const Options& o, std::string& input) {
    if (o.particles.empty()) {
        input = "procedural galaxy (" + std::to_string(o.count) + " particles)";
        return io::synthetic_galaxy(o.count);
    }
    input = o.particles;
    io::ParticleStyle style;
    style.spacing_factor = o.radius_factor;
    style.opacity = o.opacity;
    return io::spheres_from_points(io::read_points(o.particles), style);
}

bih::Tree build_tree(const Options& o, std::span<const Sphere> spheres, ThreadPool& pool) {
    bih::Config cfg;
    cfg.empty_children = o.empty_children == "infinite" ? bih::EmptyChildren::Infinite : bih::EmptyChildren::TrimBoth;
    cfg.max_leaf_elements = o.payload == "inline" ? 1u : 4u;
    cfg.trim_leaves = o.payload == "inline";
    ProgressBar bar("building BIH");
    if (!o.quiet) cfg.on_progress = [&bar](double f) { bar.update(f); };
    return bih::build(spheres, cfg, pool);
}

std::vector<std::uint32_t> encode_tree(const Options& o, const bih::Tree& t, std::span<const Sphere> spheres) {
    bih::EncodeConfig ec{o.nodes == "float32" ? bih::NodeFormat::Float32 : bih::NodeFormat::Fixed16,
                         o.layout == "preorder" ? bih::Layout::PreOrder : bih::Layout::TreeChunks, o.chunk_depth};
    if (o.payload == "inline") return bih::encode(t, spheres, ParticlePayload{}, ec);
    return bih::encode(t, spheres, bih::RangePayload{}, ec);
}

Frame render(const Options& o, std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
             const CameraFrame& cam, ThreadPool& pool, std::string& device) {
    ParticleRenderConfig rc = particle_config(o);
    if (o.backend == "cpu") {
        device = "host, " + std::to_string(pool.concurrency()) + " threads";
        return best_of(o.repeat, [&] { return render_particles_cpu(words, records, cam, o.width, o.height, pool, rc); });
    }
#ifdef SYLVA_RENDER_VULKAN
    vk::Context ctx = vk::Context::create();
    device = ctx.describe();
    vk::DeviceBih bih(ctx, words);
    return best_of(o.repeat, [&] { return vk::render_particles_vulkan(ctx, bih, records, cam, o.width, o.height, rc); });
#else
    throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
}

int run(const Options& o) {
    if (o.volume_input()) return run_volume(o);
    Stats s;
    s.backend = o.backend;
    std::vector<Sphere> spheres = load_scene(o, s.input);
    ThreadPool pool(o.threads);
    s.order = o.order;
    s.camera = o.camera;
    if (o.animate > 0) return run_particle_animation(o, spheres, pool, s);
    if (o.order == "exact") return run_particle_exact(o, spheres, pool, s);
    if (o.particle_kd()) return run_particle_kd(o, spheres, pool, s);
    if (o.particle_octree()) return run_particle_octree(o, spheres, pool, s);
    bih::Tree tree = build_tree(o, spheres, pool);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = encode_tree(o, tree, spheres);
    std::vector<std::uint32_t> records;
    if (o.payload == "range") records = pack_particles(std::span<const Sphere>(spheres), tree.order);
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    CameraFrame cam = particle_camera(o, tree.bounds);
    Frame f = render(o, words, records, cam, pool, s.device);
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill(tree, words.size() * 4 + records.size() * 4, f);
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    if (s.visible_pixels == 0)
        std::cerr << "sylva-render: nothing visible: all " << s.width << "x" << s.height
                  << " pixels are fully transparent (the image is written all the same); try a larger --opacity or "
                     "--radius-factor, or another --view\n";
    return s.errors ? 1 : 0;
}

}  // namespace
}  // namespace sylva_render

int main(int argc, char** argv) {
    sylva_render::Options opts;
    for (int i = 1; i < argc; ++i)  // -h/--help anywhere wins over bad usage elsewhere
        if (std::string(argv[i]) == "-h" || std::string(argv[i]) == "--help") {
            std::cout << sylva_render::usage();
            return 0;
        }
    try {
        opts = sylva_render::parse(argc, argv);
    } catch (const std::invalid_argument& e) {
        std::cerr << "sylva-render: " << e.what() << "\nRun sylva-render --help for the options.\n";
        return 2;
    }
    try {
        return sylva_render::run(opts);
    } catch (const std::bad_alloc&) {
        // A volume, particle set or index larger than the memory this process may use (ulimit,
        // cgroup, or the machine): say so, not just "std::bad_alloc".
        std::cerr << "sylva-render: out of memory (std::bad_alloc): the input, its index or the image needs more "
                     "memory than this process can allocate; try a smaller input, --resample, --size or --count\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "sylva-render: " << e.what() << "\n";
        return 1;
    }
}
