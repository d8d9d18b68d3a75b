// sylva/shared/rays.h -- the primary ray of a pixel for the volume integrators: one of the
// provided generators of camera.h (pinhole, orthographic) or the caller's ray buffer, chosen by
// parameter word 35 (SylvaDvrParams::ray_source, sylva/shared/dvr_common.h).
//
// Ray buffer (SYLVA_RAYS_BUFFER): a buffer `rays` of 6 words per pixel, row-major from the top
// row (pixel (x, y) at word 6 (y width + x)): origin x, y, z and direction x, y, z as float
// bits. Directions need not be unit length (the integrators normalise them); t runs from the
// origin, so the global sample lattice t_k = k dt (dvr_common.h) starts at each ray's origin.
//
// In GLSL the shader defines `uint sylva_load_rays(uint i)` before including, or
// `#define SYLVA_NO_RAYS` when it binds no ray buffer (lang.h then supplies a loader returning 0;
// a SYLVA_RAYS_BUFFER block then gives zero rays, which draw nothing). A shader may instead
// generate rays itself: `#define SYLVA_RAYS_USER` before including and define
//   SylvaRay sylva_rays_user(uint x, uint y, uint width, uint height) { ... }
// anywhere (declared here); SYLVA_RAYS_BUFFER then calls it instead of reading `rays`.
#ifndef SYLVA_SHARED_RAYS_H
#define SYLVA_SHARED_RAYS_H

#include "sylva/shared/camera.h"
#include "sylva/shared/ray_buffer.h"
#include "sylva/shared/dvr_common.h"

SYLVA_BEGIN_NAMESPACE

#if !defined(__cplusplus) && defined(SYLVA_RAYS_USER)
SylvaRay sylva_rays_user(uint x, uint y, uint width, uint height);
#endif

/// The ray of pixel (x, y) for the parameter block `params` (decoded as p): the camera of words
/// 0-11 as pinhole or orthographic, or the caller's rays.
SYLVA_FN SylvaRay sylva_pixel_ray(SYLVA_BUF(params), SYLVA_BUF(rays), SylvaDvrParams p, uint x, uint y) {
    if (p.ray_source == SYLVA_RAYS_BUFFER) {
#if !defined(__cplusplus) && defined(SYLVA_RAYS_USER)
        return sylva_rays_user(x, y, p.width, p.height);
#else
        return sylva_rays_load(SYLVA_PASS_BUF(rays), x, y, p.width);
#endif
    }
    return sylva_camera_ray(p.ray_source, sylva_param_v3(SYLVA_PASS_BUF(params), 0u),
                            sylva_param_v3(SYLVA_PASS_BUF(params), 3u), sylva_param_v3(SYLVA_PASS_BUF(params), 6u),
                            sylva_param_v3(SYLVA_PASS_BUF(params), 9u), x, y, p.width, p.height);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_RAYS_H
