// sylva-render, particles with --order exact (the default): every --index bih|kd|octree renders
// through the generic element kernel (sylva/render/elements.hpp on the host,
// sylva/vulkan/elements.hpp on Vulkan) over the library's Sphere as written once in the shared
// subset (sylva/shared/sphere_element.h). The kernel composites the spheres in exact (chord entry
// t0, index) order whatever the index, so the three indices give the same image bit for bit.
// --order leaf keeps each index's own integrator (the BIH's per-leaf sort of Kinkelin 4.2, whose
// overlapping leaves composite slightly out of order; the kd-tree's and octree's (t_c, index)
// order). Header only: main.cpp and kd_particles_scene.hpp include it.
#ifndef SYLVA_RENDER_EXACT_PARTICLES_SCENE_HPP
#define SYLVA_RENDER_EXACT_PARTICLES_SCENE_HPP

#include <chrono>
#include <iostream>
#include <span>
#include <string>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/elements/sphere.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/elements.hpp>
#include <sylva/render/image.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/spirv/elements_sphere.h>
#include <sylva/spirv/elements_sphere_kd.h>
#include <sylva/spirv/elements_sphere_octree.h>
#include <sylva/vulkan/elements.hpp>
#endif

#include "options.hpp"
#include "particle_view.hpp"
#include "stats.hpp"

namespace sylva_render {

/// The BIH of --order exact: record ranges (the generic kernel reads BIH leaves as ranges);
/// --payload inline gives single-particle trimmed leaves, range 4 particles a leaf.
inline sylva::bih::Config exact_bih_config(const Options& o) {
    sylva::bih::Config cfg;
    cfg.empty_children =
        o.empty_children == "infinite" ? sylva::bih::EmptyChildren::Infinite : sylva::bih::EmptyChildren::TrimBoth;
    cfg.max_leaf_elements = o.payload == "inline" ? 1u : 4u;
    cfg.trim_leaves = o.payload == "inline";
    return cfg;
}

/// The particles in the element order of the BIH of --order exact (exact_bih_config). The
/// generic kernel orders hits at exactly equal entry t by record index; a BIH's records are in its
/// tree order, the kd-tree's and the octree's in the order of the array they are built over. So
/// --index kd and octree are built over this order, and the three indices order such ties alike
/// (20,000 galaxy particles at 160x120: one pixel of 19,200 met two spheres with the same t0 to
/// the bit and differed by 8e-4 before). Costs one BIH build (the query layout: fast).
inline std::vector<sylva::Sphere> in_bih_order(const Options& o, std::span<const sylva::Sphere> spheres,
                                               sylva::ThreadPool& pool) {
    sylva::bih::Tree t = sylva::bih::build(spheres, exact_bih_config(o), pool);
    std::vector<sylva::Sphere> out;
    out.reserve(t.order.size());
    for (std::uint32_t i : t.order) out.push_back(spheres[i]);
    return out;
}

#ifdef SYLVA_RENDER_VULKAN
/// The generic element kernel's SPIR-V for --index: the sphere over a BIH, the kd-tree or the
/// element octree (still frames and --animate use the same choice).
inline std::span<const std::uint32_t> exact_kernel_spirv(const Options& o) {
    if (o.index == "kd") return sylva::spirv::elements_sphere_kd;
    if (o.index == "octree") return sylva::spirv::elements_sphere_octree;
    return sylva::spirv::elements_sphere;
}
#endif

/// Renders `words` (an encoding of --index: a BIH of record ranges, an element kd-tree or an
/// element octree) and `records` (pack_elements: in the BIH's order, else the caller's) through
/// the generic element kernel on --backend; names the device in `device`.
inline sylva::Frame render_exact_particles(const Options& o, std::span<const std::uint32_t> words,
                                           std::span<const std::uint32_t> records, const sylva::CameraFrame& cam,
                                           sylva::ThreadPool& pool, std::string& device) {
    using namespace sylva;
    ParticleRenderConfig rc = particle_config(o);
    // --repeat N: the fastest of N frames, the index and kernel made once (best_of).
    if (o.backend == "cpu") {
        device = "host, " + std::to_string(pool.concurrency()) + " threads";
        if (o.index == "kd")
            return best_of(o.repeat, [&] { return render_elements_cpu<Sphere, KdIndex>(words, records, cam, o.width, o.height, pool, rc); });
        if (o.index == "octree")
            return best_of(o.repeat, [&] {
                return render_elements_cpu<Sphere, OctreeIndex>(words, records, cam, o.width, o.height, pool, rc);
            });
        return best_of(o.repeat, [&] { return render_elements_cpu<Sphere, BihIndex>(words, records, cam, o.width, o.height, pool, rc); });
    }
#ifdef SYLVA_RENDER_VULKAN
    vk::Context ctx = vk::Context::create();
    device = ctx.describe();
    vk::DeviceRecords recs(ctx, records, element_words<Sphere>());
    if (o.index == "bih") {
        vk::DeviceBih bih(ctx, words);
        vk::ElementKernel kernel(ctx, exact_kernel_spirv(o));
        return best_of(o.repeat, [&] { return kernel.render(bih, recs, cam, o.width, o.height, rc); });
    }
    vk::DeviceElementIndex index(ctx, words);
    vk::ElementKernel kernel(ctx, exact_kernel_spirv(o));
    return best_of(o.repeat, [&] { return kernel.render(index, recs, cam, o.width, o.height, rc); });
#else
    throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
}

/// --order exact, still: builds --index over `spheres`, encodes it, packs the records, renders
/// through the generic kernel; fills `s` and writes the image and statistics. The exit status.
inline int run_particle_exact(const Options& o, std::span<const sylva::Sphere> spheres, sylva::ThreadPool& pool,
                              Stats& s) {
    using namespace sylva;
    std::vector<std::uint32_t> words, records;
    s.index = o.index;
    s.elements = spheres.size();
    std::vector<Sphere> canonical;  // kd, octree: the particles in the BIH's order (in_bih_order)
    if (o.index != "bih") {
        auto t0 = std::chrono::steady_clock::now();
        canonical = in_bih_order(o, spheres, pool);
        spheres = std::span<const Sphere>(canonical);
        if (!o.quiet)
            std::cout << "--order exact: particles put in the BIH's element order in "
                      << std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()
                      << " ms (ties in entry t are then ordered alike by every index)\n";
    }
    if (o.index == "kd") {
        kdtree::ElementTree t = kdtree::build_elements(spheres, kdtree::ElementConfig{}, pool);
        auto t0 = std::chrono::steady_clock::now();
        words = kdtree::encode_elements(t);
        records = pack_elements(spheres);
        s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        s.nodes = t.nodes.size();
        s.leaves = t.leaves;
        s.max_depth = t.depth;
        s.build_ms = t.build_ms;
    } else if (o.index == "octree") {
        octree::ElementTree t = octree::build_elements(spheres, octree::ElementConfig{}, pool);
        auto t0 = std::chrono::steady_clock::now();
        words = octree::encode_elements(t);
        records = pack_elements(spheres);
        s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        s.nodes = t.tree.nodes.size();
        std::size_t leaves = 0;
        std::uint32_t depth = 0;
        for (const octree::Node& n : t.tree.nodes) {
            depth = std::max(depth, n.level);
            leaves += n.leaf() ? 1u : 0u;
        }
        s.leaves = leaves;
        s.max_depth = depth;
        s.build_ms = t.build_ms;
        Stats::ElementOctreeRows& r = s.elements_octree;  // the octree's rows, as --order leaf writes them
        r.present = true;
        r.levels = t.tree.levels;
        r.octree_nodes = t.tree.nodes.size();
        r.references = t.refs.size();
        r.references_per_element =
            t.element_count ? static_cast<double>(t.refs.size()) / static_cast<double>(t.element_count) : 0.0;
        r.index_bytes = words.size() * 4;
        r.record_bytes = records.size() * 4;
    } else {
        bih::Tree t = bih::build(spheres, exact_bih_config(o), pool);
        auto t0 = std::chrono::steady_clock::now();
        words = bih::encode(t, spheres, bih::RangePayload{});
        records = pack_elements(spheres, std::span<const std::uint32_t>(t.order));
        s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        s.nodes = t.stats.nodes;
        s.leaves = t.stats.leaves;
        s.max_depth = t.stats.max_depth;
        s.single_child_percent = t.stats.percent_single_child();
        s.build_ms = t.stats.build_ms;
    }
    s.bytes = words.size() * 4 + records.size() * 4;
    CameraFrame cam = particle_camera(o, spheres);
    Frame f = render_exact_particles(o, words, records, cam, pool, s.device);
    write_frame(o.output, f, sylva::vec3(0.0f));
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
