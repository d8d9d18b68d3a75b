// sylva-render, particles with --index octree: the element octree (sylva/octree/elements.hpp)
// built over the particles' spheres, encoded (sylva/octree/elements_encode.hpp) and rendered on
// the host (sylva/render/octree_particles.hpp) or through Vulkan (sylva/vulkan/octree_particles.hpp,
// the same shared integrator as a compute shader), in exact depth order. Header only: main.cpp,
// the one includer, dispatches here.
#ifndef SYLVA_RENDER_PARTICLE_OCTREE_SCENE_HPP
#define SYLVA_RENDER_PARTICLE_OCTREE_SCENE_HPP

#include <algorithm>
#include <bit>
#include <chrono>
#include <iostream>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/octree_particles.hpp>
#include <sylva/render/particles.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/octree_particles.hpp>
#endif

#include "options.hpp"
#include "particle_view.hpp"
#include "stats.hpp"

namespace sylva_render {

/// Renders the encoded element octree on the chosen backend; names the device in `device`.
inline sylva::Frame render_particle_octree(const Options& o, std::span<const std::uint32_t> words,
                                           std::span<const std::uint32_t> records, const sylva::CameraFrame& cam,
                                           sylva::ThreadPool& pool, std::string& device) {
    using namespace sylva;
    ParticleRenderConfig rc = particle_config(o);
    if (o.backend == "cpu") {
        device = "host, " + std::to_string(pool.concurrency()) + " threads";
        return render_particles_octree_cpu(words, records, cam, o.width, o.height, pool, rc);
    }
#ifdef SYLVA_RENDER_VULKAN
    vk::Context ctx = vk::Context::create();
    device = ctx.describe();
    vk::DeviceElementOctree oct(ctx, words, records);
    return vk::render_particles_octree_vulkan(ctx, oct, cam, o.width, o.height, rc);
#else
    throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
}

/// Builds, encodes and renders `spheres` through the element octree; fills `s` (input already
/// set) and writes the image, heat map and statistics. Returns the exit status.
inline int run_particle_octree(const Options& o, std::span<const sylva::Sphere> spheres, sylva::ThreadPool& pool,
                               Stats& s) {
    using namespace sylva;
    octree::ElementTree et = octree::build_elements(spheres, octree::ElementConfig{}, pool);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = octree::encode_elements(et);
    std::vector<std::uint32_t> identity(spheres.size());
    std::iota(identity.begin(), identity.end(), 0u);
    std::vector<std::uint32_t> records = pack_particles(spheres, std::span<const std::uint32_t>(identity));
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    CameraFrame cam = particle_camera(o, spheres);
    Frame f = render_particle_octree(o, words, records, cam, pool, s.device);

    s.index = "octree";
    s.elements = et.element_count;
    s.nodes = et.tree.nodes.size();
    std::size_t leaves = 0, inner = 0, single = 0;
    std::uint32_t depth = 0;
    for (const octree::Node& n : et.tree.nodes) {
        depth = std::max(depth, n.level);
        if (n.leaf()) {
            ++leaves;
        } else {
            ++inner;
            single += std::popcount(n.child_mask) == 1 ? 1u : 0u;
        }
    }
    s.leaves = leaves;
    s.max_depth = depth;
    s.single_child_percent = inner ? 100.0 * static_cast<double>(single) / static_cast<double>(inner) : 0.0;
    s.build_ms = et.build_ms;
    Stats::ElementOctreeRows& r = s.elements_octree;
    r.present = true;
    r.levels = et.tree.levels;
    r.octree_nodes = et.tree.nodes.size();
    r.references = et.refs.size();
    r.references_per_element =
        et.element_count ? static_cast<double>(et.refs.size()) / static_cast<double>(et.element_count) : 0.0;
    r.index_bytes = words.size() * 4;
    r.record_bytes = records.size() * 4;
    s.bytes = r.index_bytes + r.record_bytes;

    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);  // counts the rays that met a refused encoding (steps 0xFFFFFFFF) as errors
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    if (s.visible_pixels == 0)
        std::cerr << "sylva-render: nothing visible: all " << s.width << "x" << s.height
                  << " pixels are fully transparent (the image is written all the same); try a larger --opacity or "
                     "--radius-factor, or another --view\n";
    return s.errors ? 1 : 0;
}

}  // namespace sylva_render

#endif
