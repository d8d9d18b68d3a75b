// sylva/render/particles.hpp -- renders particles through an encoded BIH on the host, with the
// same shared integrator the shader runs, over all cores of an executor.
#ifndef SYLVA_RENDER_PARTICLES_HPP
#define SYLVA_RENDER_PARTICLES_HPP

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/rays.hpp"
#include "sylva/shared/particles.h"

namespace sylva {

/// A rendered frame: premultiplied RGBA per pixel (row-major, y down), iterator steps per
/// pixel (the traversal-cost heat map; 0xFFFFFFFF marks a corrupted-encoding error), time.
struct Frame {
    std::uint32_t width = 0, height = 0;
    std::vector<vec4> rgba;
    std::vector<std::uint32_t> steps;
    double ms = 0.0;
};

/// Settings shared by the particle renderers.
struct ParticleRenderConfig {
    /// Early ray termination: stop once the accumulated opacity reaches this (Kinkelin 5.3).
    float alpha_stop = 0.99f;
    /// Primary rays: the camera as a pinhole (default) or orthographic, or the caller's rays
    /// (sylva/render/rays.hpp; every particle and element renderer, host and Vulkan).
    PixelRays rays{};
};

/// Throws sylva::Error unless `kind` (an encoded BIH's payload kind, header bits 8-15) is one the
/// particle integrator draws: SYLVA_PAYLOAD_RANGE (records in `records`, 8 words each, at most
/// SYLVA_PARTICLE_MAX_RECORDS of them) or SYLVA_PAYLOAD_PARTICLE_RGBA (inline). A LoD or voxel
/// BIH, or a user kind, would otherwise be drawn as garbage.
inline void check_particle_payload(std::uint32_t kind, std::size_t record_words, const char* who) {
    if (kind != SYLVA_PAYLOAD_RANGE && kind != SYLVA_PAYLOAD_PARTICLE_RGBA)
        throw Error(std::string(who) + ": the BIH's payload kind " + std::to_string(kind) +
                    (kind == SYLVA_PAYLOAD_VOXEL ? " (voxel / LoD)" : "") +
                    " is not a particle kind (0: record ranges, 1: inline RGBA particles)");
    if (kind == SYLVA_PAYLOAD_RANGE && record_words % SYLVA_PARTICLE_WORDS != 0)
        throw Error(std::string(who) + ": " + std::to_string(record_words) +
                    " record words are not a whole number of 8-word particle records");
    if (kind == SYLVA_PAYLOAD_RANGE && record_words / SYLVA_PARTICLE_WORDS > SYLVA_PARTICLE_MAX_RECORDS)
        throw Error(std::string(who) + ": " + std::to_string(record_words / SYLVA_PARTICLE_WORDS) +
                    " particle records are more than 32-bit word indices address (2^29)");
}

namespace detail {

/// The pixel loop of the particle and element renderers: for each pixel of a width x height
/// frame, its primary ray (cfg.rays, pixel_ray) and rgba = integrate(origin, direction, steps,
/// status) with the shared integrator, rows spread over exec's threads; a pixel whose status is
/// SYLVA_ITER_ERROR (a corrupted encoding) gets steps 0xFFFFFFFF. Throws sylva::Error for a
/// ray buffer that does not fit the frame (check_rays).
template <Executor X, class Integrate>
Frame render_pixel_rays(const CameraFrame& cam, std::uint32_t width, std::uint32_t height, X& exec,
                        const ParticleRenderConfig& cfg, Integrate&& integrate) {
    check_rays(cfg.rays, width, height);
    auto start = std::chrono::steady_clock::now();
    Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
    parallel_take(exec, 0, height, kRowsPerTake, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y) {
            for (std::uint32_t x = 0; x < width; ++x) {
                Ray r = pixel_ray(cam, cfg.rays, x, static_cast<std::uint32_t>(y), width, height);
                std::uint32_t steps, status;
                std::size_t i = y * width + x;
                f.rgba[i] = integrate(r.origin, r.direction, steps, status);
                f.steps[i] = status == SYLVA_ITER_ERROR ? 0xFFFFFFFFu : steps;
            }
        }
    });
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return f;
}

/// Throws sylva::Error unless `records` is a whole number of 8-word particle records, at most
/// SYLVA_PARTICLE_MAX_RECORDS, and at least the `index_elements` elements the encoded element
/// index names (`who`: the renderer, `index`: "kd-tree" or "octree", for the message). Returns
/// the record count.
inline std::uint32_t check_particle_records(std::span<const std::uint32_t> records, std::uint32_t index_elements,
                                            const char* who, const char* index) {
    if (records.size() % SYLVA_PARTICLE_WORDS != 0 || records.size() / SYLVA_PARTICLE_WORDS > SYLVA_PARTICLE_MAX_RECORDS)
        throw Error(std::string(who) + ": " + std::to_string(records.size()) +
                    " record words are not a whole number of 8-word particle records below 2^29");
    auto n = static_cast<std::uint32_t>(records.size() / SYLVA_PARTICLE_WORDS);
    if (index_elements > n)
        throw Error(std::string(who) + ": the " + index + " names " + std::to_string(index_elements) +
                    " elements, the records hold " + std::to_string(n));
    return n;
}

/// The encoding's word count as the shared code takes it (clamped to 2^32 - 1: a longer buffer
/// then fails the header's size check there).
inline std::uint32_t word_count32(std::span<const std::uint32_t> words) {
    return static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
}

}  // namespace detail

/// Renders `words` (an encoded particle BIH) with `records` (pack_particles output; empty for
/// inline payloads) on the host. Throws sylva::Error when the encoding's payload kind is not a
/// particle kind (check_particle_payload); a corrupted encoding instead marks its pixels'
/// steps 0xFFFFFFFF.
template <Executor X>
Frame render_particles_cpu(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                           const CameraFrame& cam, std::uint32_t width, std::uint32_t height, X& exec,
                           const ParticleRenderConfig& cfg = {}) {
    if (words.size() >= SYLVA_BIH_HEADER_WORDS && words[0] == SYLVA_BIH_MAGIC)
        check_particle_payload((words[2] >> 8) & 255u, records.size(), "render_particles_cpu");
    shared::Words w{words.data(), words.size()}, e{records.data(), records.size()};
    const std::uint32_t word_count = detail::word_count32(words);
    return detail::render_pixel_rays(cam, width, height, exec, cfg,
                                     [&](vec3 o, vec3 d, std::uint32_t& steps, std::uint32_t& status) {
                                         return shared::sylva_render_particles(w, word_count, e, o, d, 0.0f,
                                                                               shared::sylva_inf(), cfg.alpha_stop,
                                                                               steps, status);
                                     });
}

}  // namespace sylva

#endif  // SYLVA_RENDER_PARTICLES_HPP
