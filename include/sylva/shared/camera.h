// sylva/shared/camera.h -- the provided ray generators, pinhole and orthographic, identical on
// host and GPU.
//
// A camera is 12 floats (as words, e.g. in push constants or parameter words 0-11): eye (0-2),
// forward w (3-5), right u (6-8), up v (9-11). Pixel (x, y) of a width x height image, y down,
// has image-plane coordinates through its centre
//   sx = (x + 0.5) / width * 2 - 1,    sy = 1 - (y + 0.5) / height * 2    (both in (-1, 1)).
//  * Pinhole (SYLVA_RAYS_PINHOLE): origin eye, direction w + sx u + sy v; |u| and |v| are the
//    half-extents of the image plane at distance |w|.
//  * Orthographic (SYLVA_RAYS_ORTHO): origin eye + sx u + sy v, direction w; |u| and |v| are
//    the half-width and half-height of the view rectangle in world units, centred on the eye
//    (the eye sits on the image plane, rays start there and run along w).
// Both are written out component by component (no fma contraction, same rounding on both targets).
#ifndef SYLVA_SHARED_CAMERA_H
#define SYLVA_SHARED_CAMERA_H

#include "sylva/shared/lang.h"

#define SYLVA_RAYS_PINHOLE 0u
#define SYLVA_RAYS_ORTHO 1u
#define SYLVA_RAYS_BUFFER 2u

SYLVA_BEGIN_NAMESPACE

/// A primary ray: origin and (not necessarily unit) direction.
struct SylvaRay {
    vec3 origin;
    vec3 dir;
};

/// Image-plane coordinates (sx, sy) of the centre of pixel (x, y), see the top.
SYLVA_FN vec2 sylva_camera_plane(uint x, uint y, uint width, uint height) {
    float sx = (float(x) + 0.5f) / float(width) * 2.0f - 1.0f;
    float sy = 1.0f - (float(y) + 0.5f) / float(height) * 2.0f;
    return vec2(sx, sy);
}

/// a + sx u + sy v, written out.
SYLVA_FN vec3 sylva_camera_offset(vec3 a, vec3 u, vec3 v, vec2 s) {
    SYLVA_PRECISE vec3 r = vec3(a.x + s.x * u.x + s.y * v.x, a.y + s.x * u.y + s.y * v.y, a.z + s.x * u.z + s.y * v.z);
    return r;
}

/// Direction of the pinhole ray through the centre of pixel (x, y) of a width x height image.
SYLVA_FN vec3 sylva_camera_dir(vec3 w, vec3 u, vec3 v, uint x, uint y, uint width, uint height) {
    vec2 s = sylva_camera_plane(x, y, width, height);
    return vec3(w.x + s.x * u.x + s.y * v.x, w.y + s.x * u.y + s.y * v.y, w.z + s.x * u.z + s.y * v.z);
}

/// Origin of the orthographic ray of pixel (x, y): eye + sx u + sy v (its direction is w).
SYLVA_FN vec3 sylva_camera_ortho_origin(vec3 eye, vec3 u, vec3 v, uint x, uint y, uint width, uint height) {
    return sylva_camera_offset(eye, u, v, sylva_camera_plane(x, y, width, height));
}

/// The ray of pixel (x, y) for camera source `source` (SYLVA_RAYS_ORTHO, else pinhole).
SYLVA_FN SylvaRay sylva_camera_ray(uint source, vec3 eye, vec3 w, vec3 u, vec3 v, uint x, uint y, uint width,
                                   uint height) {
    SylvaRay r;
    if (source == SYLVA_RAYS_ORTHO) {
        r.origin = sylva_camera_ortho_origin(eye, u, v, x, y, width, height);
        r.dir = w;
    } else {
        r.origin = eye;
        r.dir = sylva_camera_dir(w, u, v, x, y, width, height);
    }
    return r;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_CAMERA_H
