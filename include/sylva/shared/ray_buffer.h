// sylva/shared/ray_buffer.h -- the caller's primary rays as a buffer `rays` of 6 words a pixel,
// row-major from the top row (pixel (x, y) at word 6 (y width + x)): origin x, y, z and
// direction x, y, z as float bits (directions need not be unit length). rays.h reads them for
// the volume kernels (parameter word 35); the particle and element kernels, whose camera comes in
// push constants, pick their rays with sylva_pixel_ray_from.
//
// In GLSL the shader defines `uint sylva_load_rays(uint i)` (0 past the buffer) before
// including, or `#define SYLVA_NO_RAYS` when it binds no ray buffer (lang.h).
#ifndef SYLVA_SHARED_RAY_BUFFER_H
#define SYLVA_SHARED_RAY_BUFFER_H

#include "sylva/shared/camera.h"

SYLVA_BEGIN_NAMESPACE

/// Ray of pixel (x, y) from a ray buffer (see the top); words past the buffer read 0.
SYLVA_FN SylvaRay sylva_rays_load(SYLVA_BUF(rays), uint x, uint y, uint width) {
    uint at = (y * width + x) * 6u;
    SylvaRay r;
    r.origin = vec3(uintBitsToFloat(SYLVA_LOAD(rays, at)), uintBitsToFloat(SYLVA_LOAD(rays, at + 1u)),
                    uintBitsToFloat(SYLVA_LOAD(rays, at + 2u)));
    r.dir = vec3(uintBitsToFloat(SYLVA_LOAD(rays, at + 3u)), uintBitsToFloat(SYLVA_LOAD(rays, at + 4u)),
                 uintBitsToFloat(SYLVA_LOAD(rays, at + 5u)));
    return r;
}

/// The ray of pixel (x, y) of a width x height image: for SYLVA_RAYS_BUFFER the caller's ray from
/// `rays`, else the camera (eye, w, u, v) as a pinhole or orthographic (camera.h).
SYLVA_FN SylvaRay sylva_pixel_ray_from(SYLVA_BUF(rays), uint source, vec3 eye, vec3 w, vec3 u, vec3 v, uint x, uint y, uint width,
                                       uint height) {
    if (source == SYLVA_RAYS_BUFFER) return sylva_rays_load(SYLVA_PASS_BUF(rays), x, y, width);
    return sylva_camera_ray(source, eye, w, u, v, x, y, width, height);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_RAY_BUFFER_H
