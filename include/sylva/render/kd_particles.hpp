// sylva/render/kd_particles.hpp -- renders particles through an encoded element kd-tree
// (sylva/kdtree/elements_encode.hpp) on the host, with the shared integrator the shader runs
// (sylva/shared/kd_elem_particles.h), over all cores of an executor. The kd-tree twin of
// sylva/render/particles.hpp's render_particles_cpu; same Frame and settings.
#ifndef SYLVA_RENDER_KD_PARTICLES_HPP
#define SYLVA_RENDER_KD_PARTICLES_HPP

#include <cstdint>
#include <span>

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
    const std::uint32_t n =
        detail::check_particle_records(records, words.size() > 3 ? words[3] : 0u, "render_particles_kd_cpu", "kd-tree");
    shared::Words w{words.data(), words.size()}, e{records.data(), records.size()};
    const std::uint32_t word_count = detail::word_count32(words);
    return detail::render_pixel_rays(cam, width, height, exec, cfg,
                                     [&](vec3 o, vec3 d, std::uint32_t& steps, std::uint32_t& status) {
                                         return shared::sylva_kde_render_particles(w, word_count, e, n, o, d, 0.0f,
                                                                                   shared::sylva_inf(), cfg.alpha_stop,
                                                                                   steps, status);
                                     });
}

}  // namespace sylva

#endif  // SYLVA_RENDER_KD_PARTICLES_HPP
