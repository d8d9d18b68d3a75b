// sylva-render, particles with --index kd --order leaf (the element kd-tree,
// sylva/kdtree/elements.hpp, through its own integrator: the element octree's exact depth order
// over SAH planes), and the camera and output shared by the particle scenes. Header only:
// main.cpp and animation_scene.hpp (moving particles) include it.
#ifndef SYLVA_RENDER_KD_PARTICLES_SCENE_HPP
#define SYLVA_RENDER_KD_PARTICLES_SCENE_HPP

#include <chrono>
#include <iostream>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/kd_particles.hpp>
#include <sylva/render/particles.hpp>

#include "options.hpp"
#include "particle_view.hpp"
#include "stats.hpp"

namespace sylva_render {

/// Writes the frame and the statistics; the exit status.
inline int finish_particle_frame(const Options& o, const sylva::Frame& f, Stats& s) {
    write_frame(o.output, f, sylva::vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    return s.errors ? 1 : 0;
}

/// Builds, encodes and renders `spheres` through the element kd-tree on the host.
inline int run_particle_kd(const Options& o, std::span<const sylva::Sphere> spheres, sylva::ThreadPool& pool, Stats& s) {
    using namespace sylva;
    if (o.backend != "cpu") throw Error(leaf_kd_host_only);  // parse() refuses it first
    kdtree::ElementTree t = kdtree::build_elements(spheres, kdtree::ElementConfig{}, pool);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = kdtree::encode_elements(t);
    std::vector<std::uint32_t> identity(spheres.size());
    std::iota(identity.begin(), identity.end(), 0u);
    std::vector<std::uint32_t> records = pack_particles(spheres, std::span<const std::uint32_t>(identity));
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
    Frame f = render_particles_kd_cpu(words, records, particle_camera(o, spheres), o.width, o.height, pool,
                                      particle_config(o));
    s.index = "kd";
    s.elements = spheres.size();
    s.nodes = t.nodes.size();
    s.leaves = t.leaves;
    s.max_depth = t.depth;
    s.build_ms = t.build_ms;
    s.bytes = words.size() * 4 + records.size() * 4;
    if (!o.quiet)
        std::cout << "kd-tree: " << t.refs.size() << " references ("
                  << (spheres.empty() ? 0.0 : double(t.refs.size()) / double(spheres.size())) << " per particle)\n";
    return finish_particle_frame(o, f, s);
}

}  // namespace sylva_render

#endif
