// sylva-render, particles with --index kd (the element kd-tree, sylva/kdtree/elements.hpp: the
// element octree's exact depth order over SAH planes) and moving particles (--animate N with
// --index bih|kd|octree, --update refit|rebuild). Header only: main.cpp, the one includer,
// dispatches here.
//
// Motion (deterministic, the same in every run): particle i oscillates along its own unit
// direction d_i (from the golden angle) by A sin(2 pi f / 16 + i), A = 2 % of the particles'
// box's largest extent; frame f = 1..N. Per frame the index follows (refit or rebuild), is
// encoded, the records are packed and the frame is rendered; the last frame is written. The BIH
// is the query layout (4 particles a leaf, untrimmed, RangePayload records) whatever --payload
// says: a refit keeps leaves, so leaves trimmed to one particle would not stay trimmed.
#ifndef SYLVA_RENDER_KD_PARTICLES_SCENE_HPP
#define SYLVA_RENDER_KD_PARTICLES_SCENE_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/refit.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/elements_refit.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/kd_particles.hpp>
#include <sylva/render/octree_particles.hpp>
#include <sylva/render/particles.hpp>

#include "exact_particles_scene.hpp"
#include "options.hpp"
#include "stats.hpp"

namespace sylva_render {

/// The camera every particle scene uses: framing the particles' box from --view.
inline sylva::CameraFrame particle_camera(const Options& o, std::span<const sylva::Sphere> spheres) {
    using namespace sylva;
    Aabb box;
    for (const Sphere& p : spheres) box.extend(bounds_of(p));
    vec3 from = o.view ? vec3((*o.view)[0], (*o.view)[1], (*o.view)[2]) : vec3(0.4f, 0.7f, 1.0f);
    return Camera::framing(box, from).frame(o.width, o.height);
}

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
    if (o.backend != "cpu")
        throw Error("--index kd renders particles on --backend cpu (the shared iterator sylva/shared/kd_elem_iter.h "
                    "has no kernel of its own yet)");
    kdtree::ElementTree t = kdtree::build_elements(spheres, kdtree::ElementConfig{}, pool);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = kdtree::encode_elements(t);
    std::vector<std::uint32_t> identity(spheres.size());
    std::iota(identity.begin(), identity.end(), 0u);
    std::vector<std::uint32_t> records = pack_particles(spheres, std::span<const std::uint32_t>(identity));
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
    Frame f = render_particles_kd_cpu(words, records, particle_camera(o, spheres), o.width, o.height, pool,
                                      ParticleRenderConfig{o.alpha_stop});
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

/// Frame `frame` of the deterministic motion of `base` into `out`.
inline void move_particles(std::span<const sylva::Sphere> base, std::uint32_t frame, float amplitude,
                           std::vector<sylva::Sphere>& out, sylva::ThreadPool& pool) {
    using namespace sylva;
    out.resize(base.size());
    pool.parallel_for(0, base.size(), 16384, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            float a = float(i) * 2.39996323f, z = 1.0f - 2.0f * float(i % 1024) / 1023.0f, r = std::sqrt(1.0f - z * z);
            vec3 d(r * std::cos(a), r * std::sin(a), z);
            out[i] = base[i];
            out[i].center += amplitude * std::sin(6.2831853f * float(frame) / 16.0f + float(i)) * d;
        }
    });
}

/// --animate N: moves the particles for N frames, refitting or rebuilding the index per frame;
/// prints per-frame update, encode and render times and their medians; writes the last frame.
inline int run_particle_animation(const Options& o, std::span<const sylva::Sphere> base, sylva::ThreadPool& pool,
                                  Stats& s) {
    using namespace sylva;
    Aabb box;
    for (const Sphere& p : base) box.extend(bounds_of(p));
    vec3 ext = box.empty() ? vec3(1.0f) : box.extent();
    float amplitude = 0.02f * std::max({ext.x, ext.y, ext.z});
    const bool refit = o.update == "refit";
    std::vector<Sphere> now(base.begin(), base.end());
    std::span<const Sphere> cur(now);
    CameraFrame cam = particle_camera(o, base);
    ParticleRenderConfig rc{o.alpha_stop};
    std::vector<std::uint32_t> identity(base.size());
    std::iota(identity.begin(), identity.end(), 0u);

    bih::Config bcfg;
    bcfg.max_leaf_elements = 4;
    bcfg.trim_leaves = false;
    bcfg.empty_children = o.empty_children == "infinite" ? bih::EmptyChildren::Infinite : bih::EmptyChildren::TrimBoth;
    kdtree::ElementConfig kcfg;
    octree::ElementConfig ocfg;
    bih::Tree bt;
    kdtree::ElementTree kt;
    octree::ElementTree ot;
    auto ms_since = [](std::chrono::steady_clock::time_point a) {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count();
    };
    auto t0 = std::chrono::steady_clock::now();
    if (o.index == "bih") bt = bih::build(cur, bcfg, pool);
    else if (o.index == "kd") kt = kdtree::build_elements(cur, kcfg, pool);
    else ot = octree::build_elements(cur, ocfg, pool);
    s.build_ms = ms_since(t0);
    std::vector<double> update_ms, encode_ms, render_ms;
    std::size_t fallbacks = 0;
    Frame f;
    for (std::uint32_t frame = 1; frame <= o.animate; ++frame) {
        move_particles(base, frame, amplitude, now, pool);
        cur = std::span<const Sphere>(now);
        t0 = std::chrono::steady_clock::now();
        if (o.index == "bih") {
            if (refit) bih::refit(bt, cur, pool);
            else bih::rebuild(bt, cur, bcfg, pool);
        } else if (o.index == "kd") {
            if (refit) kdtree::refit_elements(kt, cur, kcfg, pool);
            else kdtree::rebuild_elements(kt, cur, kcfg, pool);
        } else if (refit) {
            fallbacks += octree::update_elements(ot, cur, ocfg, pool) ? 0u : 1u;
        } else {
            octree::rebuild_elements(ot, cur, ocfg, pool);
        }
        update_ms.push_back(ms_since(t0));
        t0 = std::chrono::steady_clock::now();
        std::vector<std::uint32_t> words, records;
        if (o.index == "bih") {
            words = bih::encode(bt, cur, bih::RangePayload{});
            records = pack_particles(cur, std::span<const std::uint32_t>(bt.order));
        } else {
            words = o.index == "kd" ? kdtree::encode_elements(kt) : octree::encode_elements(ot);
            records = pack_particles(cur, std::span<const std::uint32_t>(identity));
        }
        encode_ms.push_back(ms_since(t0));
        if (o.order == "exact") f = render_exact_particles(o, words, records, cam, pool, s.device);  // --order exact
        else if (o.index == "bih") f = render_particles_cpu(words, records, cam, o.width, o.height, pool, rc);
        else if (o.index == "kd") f = render_particles_kd_cpu(words, records, cam, o.width, o.height, pool, rc);
        else f = render_particles_octree_cpu(words, records, cam, o.width, o.height, pool, rc);
        render_ms.push_back(f.ms);
        s.bytes = words.size() * 4 + records.size() * 4;
        if (!o.quiet)
            std::cout << "frame " << frame << ": " << o.update << " " << std::fixed << std::setprecision(2) << update_ms.back()
                      << " ms, encode " << encode_ms.back() << " ms, render " << render_ms.back() << " ms\n"
                      << std::defaultfloat;
    }
    auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v.empty() ? 0.0 : v[v.size() / 2];
    };
    if (!o.quiet) {
        std::cout << "animation: " << o.animate << " frames, --index " << o.index << " --update " << o.update
                  << ": median update " << median(update_ms) << " ms, encode " << median(encode_ms) << " ms, render "
                  << median(render_ms) << " ms (first build " << s.build_ms << " ms)";
        if (fallbacks) std::cout << "; " << fallbacks << " octree refits fell back to a rebuild (particles left the lattice)";
        std::cout << "\n";
    }
    s.index = o.index;
    s.elements = base.size();
    s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
    return finish_particle_frame(o, f, s);
}

}  // namespace sylva_render

#endif
