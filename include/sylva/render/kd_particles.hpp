// sylva/render/kd_particles.hpp -- renders particles through an encoded element kd-tree
// (sylva/kdtree/elements_encode.hpp) on the host, with the shared integrator the shader runs
// (sylva/shared/kd_elem_particles.h), over all cores of an executor. The kd-tree twin of
// sylva/render/particles.hpp's render_particles_cpu; same Frame and settings.
#ifndef SYLVA_RENDER_KD_PARTICLES_HPP
#define SYLVA_RENDER_KD_PARTICLES_HPP

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/shared/kd_elem_particles.h"

namespace sylva {

/// Renders `words` (an element kd-tree built over the particles) with `records` (their 8-word
/// records in the same element order: pack_particles with the identity order). Throws
/// sylva::Error when the records are not whole or fewer than the kd-tree's elements; a corrupted
/// encoding marks its pixels' steps 0xFFFFFFFF.
template <Executor X>
Frame render_particles_kd_cpu(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                                  const CameraFrame& cam, std::uint32_t width, std::uint32_t height, X& exec,
                                  const ParticleRenderConfig& cfg = {}) {
    if (records.size() % SYLVA_PARTICLE_WORDS != 0 || records.size() / SYLVA_PARTICLE_WORDS > SYLVA_PARTICLE_MAX_RECORDS)
        throw Error("render_particles_kd_cpu: " + std::to_string(records.size()) +
                    " record words are not a whole number of 8-word particle records below 2^29");
    if (words.size() > 3 && words[3] > records.size() / SYLVA_PARTICLE_WORDS)
        throw Error("render_particles_kd_cpu: the kd-tree names " + std::to_string(words[7]) + " elements, the records hold " +
                    std::to_string(records.size() / SYLVA_PARTICLE_WORDS));
    check_rays(cfg.rays, width, height);
    auto start = std::chrono::steady_clock::now();
    Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
    shared::Words w{words.data(), words.size()}, e{records.data(), records.size()};
    auto word_count = static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    auto n = static_cast<std::uint32_t>(records.size() / SYLVA_PARTICLE_WORDS);
    exec.parallel_for(0, height, 1, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y) {
            for (std::uint32_t x = 0; x < width; ++x) {
                Ray r = pixel_ray(cam, cfg.rays, x, static_cast<std::uint32_t>(y), width, height);
                std::uint32_t steps, status;
                std::size_t i = y * width + x;
                f.rgba[i] = shared::sylva_kde_render_particles(w, word_count, e, n, r.origin, r.direction, 0.0f,
                                                                shared::sylva_inf(), cfg.alpha_stop, steps, status);
                f.steps[i] = status == SYLVA_ITER_ERROR ? 0xFFFFFFFFu : steps;
            }
        }
    });
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return f;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_KD_PARTICLES_HPP
