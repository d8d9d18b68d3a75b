// sylva/render/rays.hpp -- where a renderer's primary rays come from: the provided generators
// (pinhole and orthographic camera, sylva/shared/camera.h) or the caller's rays, as a buffer of
// 6 floats a pixel or a host callable. Every volume and isosurface renderer, host and Vulkan,
// takes a PixelRays beside its CameraFrame (VolumeRenderParams::rays, IsoRenderParams::rays).
//
//   VolumeRenderParams p;
//   p.camera = Camera::framing(box).ortho_frame(w, h, radius);  // u, v: half extents in world units
//   p.rays.source = RaySource::Ortho;                           // origin eye + sx u + sy v, direction w
//   // or the caller's rays (path tracer, VR eye): 6 floats a pixel, origin then direction ...
//   p.rays = PixelRays::from_buffer(my_rays);
//   // ... or a callable, evaluated per pixel on the host and into a ray buffer for Vulkan:
//   p.rays = PixelRays::from_function([&](std::uint32_t x, std::uint32_t y) { return Ray{o, d}; });
//
// The ray parameter t runs from each ray's origin and the sample lattice t_k = k dt starts
// there (sylva/shared/dvr_common.h), so a buffer equal to a camera's rays gives that camera's
// image bit for bit.
#ifndef SYLVA_RENDER_RAYS_HPP
#define SYLVA_RENDER_RAYS_HPP

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/ray.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/shared/camera.h"

namespace sylva {

/// Which generator makes the primary rays (parameter word 35, sylva/shared/rays.h).
enum class RaySource : std::uint32_t {
    Pinhole = SYLVA_RAYS_PINHOLE,  ///< CameraFrame as a pinhole: origin eye, direction w + sx u + sy v
    Ortho = SYLVA_RAYS_ORTHO,      ///< CameraFrame as orthographic: origin eye + sx u + sy v, direction w
    Buffer = SYLVA_RAYS_BUFFER,    ///< the caller's rays: PixelRays::buffer or PixelRays::generate
};

/// Where the primary rays come from. Default: the pinhole camera.
struct PixelRays {
    RaySource source = RaySource::Pinhole;
    /// RaySource::Buffer: 6 floats a pixel, row-major from the top row: origin x, y, z, direction
    /// x, y, z (need not be unit length). Its size must be 6 * width * height.
    std::vector<float> buffer;
    /// RaySource::Buffer alternative: the ray of pixel (x, y), called from several threads at
    /// once on the host; Vulkan renderers evaluate it into a buffer. Used when set.
    std::function<Ray(std::uint32_t x, std::uint32_t y)> generate;

    static PixelRays from_buffer(std::vector<float> rays) { return {RaySource::Buffer, std::move(rays), {}}; }
    static PixelRays from_function(std::function<Ray(std::uint32_t, std::uint32_t)> f) {
        return {RaySource::Buffer, {}, std::move(f)};
    }
};

/// The ray of pixel (x, y) of a width x height image (same arithmetic as the shaders).
inline Ray pixel_ray(const CameraFrame& cam, const PixelRays& rays, std::uint32_t x, std::uint32_t y,
                     std::uint32_t width, std::uint32_t height) {
    if (rays.source == RaySource::Buffer) {
        if (rays.generate) return rays.generate(x, y);
        std::size_t at = (std::size_t{y} * width + x) * 6;
        if (at + 6 > rays.buffer.size()) return Ray{vec3(0.0f), vec3(0.0f)};
        const float* r = &rays.buffer[at];
        return Ray{vec3(r[0], r[1], r[2]), vec3(r[3], r[4], r[5])};
    }
    shared::SylvaRay r = shared::sylva_camera_ray(static_cast<std::uint32_t>(rays.source), cam.eye, cam.w, cam.u, cam.v,
                                                  x, y, width, height);
    return Ray{r.origin, r.dir};
}

/// Every pixel's ray as a ray buffer (6 floats a pixel, see PixelRays::buffer): what a Vulkan
/// renderer uploads for RaySource::Buffer, and a camera's rays for a caller to edit.
inline std::vector<float> ray_buffer(const CameraFrame& cam, const PixelRays& rays, std::uint32_t width,
                                     std::uint32_t height) {
    if (rays.source == RaySource::Buffer && !rays.generate) return rays.buffer;
    std::vector<float> out(std::size_t{width} * height * 6);
    for (std::uint32_t y = 0; y < height; ++y)
        for (std::uint32_t x = 0; x < width; ++x) {
            Ray r = pixel_ray(cam, rays, x, y, width, height);
            float* o = &out[(std::size_t{y} * width + x) * 6];
            o[0] = r.origin.x, o[1] = r.origin.y, o[2] = r.origin.z;
            o[3] = r.direction.x, o[4] = r.direction.y, o[5] = r.direction.z;
        }
    return out;
}

/// Throws sylva::Error for an unknown source, or a ray buffer of the wrong size or holding a
/// non-finite number.
inline void check_rays(const PixelRays& rays, std::uint32_t width, std::uint32_t height) {
    auto s = static_cast<std::uint32_t>(rays.source);
    if (s > SYLVA_RAYS_BUFFER) throw Error("render: unknown ray source " + std::to_string(s));
    if (rays.source != RaySource::Buffer || rays.generate) return;
    std::size_t want = std::size_t{width} * height * 6;
    if (rays.buffer.size() != want)
        throw Error("render: the ray buffer holds " + std::to_string(rays.buffer.size()) + " floats, a " +
                    std::to_string(width) + "x" + std::to_string(height) + " image needs " + std::to_string(want) +
                    " (6 a pixel)");
    for (std::size_t i = 0; i < want; ++i)
        if (!std::isfinite(rays.buffer[i]))
            throw Error("render: ray buffer float " + std::to_string(i) + " (pixel " + std::to_string(i / 6) +
                        ") is not finite");
}

/// The box holding every ray origin (for the lattice reach check of the volume renderers).
/// A callable is evaluated once per pixel.
inline Aabb ray_origin_box(const CameraFrame& cam, const PixelRays& rays, std::uint32_t width, std::uint32_t height) {
    if (rays.source == RaySource::Pinhole) return Aabb{cam.eye, cam.eye};
    if (rays.source == RaySource::Ortho) {
        vec3 lo = cam.eye, hi = cam.eye;
        for (float sx : {-1.0f, 1.0f})
            for (float sy : {-1.0f, 1.0f}) {
                vec3 c = cam.eye + sx * cam.u + sy * cam.v;
                lo = glm::min(lo, c), hi = glm::max(hi, c);
            }
        return Aabb{lo, hi};
    }
    Aabb box{vec3(shared::sylva_inf()), vec3(-shared::sylva_inf())};
    for (std::uint32_t y = 0; y < height; ++y)
        for (std::uint32_t x = 0; x < width; ++x) {
            vec3 o = pixel_ray(cam, rays, x, y, width, height).origin;
            box.lo = glm::min(box.lo, o), box.hi = glm::max(box.hi, o);
        }
    return box;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_RAYS_HPP
