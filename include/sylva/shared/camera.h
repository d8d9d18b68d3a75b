// sylva/shared/camera.h -- pinhole camera rays, identical on host and GPU.
//
// A camera is 12 floats (as words, e.g. in push constants): eye (0-2), forward w (3-5),
// right u (6-8), up v (9-11), with |u| and |v| the half-extents of the image plane at
// distance |w|. Pixel (x, y), y down, gets the ray eye + t (w + sx u + sy v) through its centre.
#ifndef SYLVA_SHARED_CAMERA_H
#define SYLVA_SHARED_CAMERA_H

#include "sylva/shared/lang.h"

SYLVA_BEGIN_NAMESPACE

/// Direction of the ray through the centre of pixel (x, y) of a width x height image.
SYLVA_FN vec3 sylva_camera_dir(vec3 w, vec3 u, vec3 v, uint x, uint y, uint width, uint height) {
    float sx = (float(x) + 0.5f) / float(width) * 2.0f - 1.0f;
    float sy = 1.0f - (float(y) + 0.5f) / float(height) * 2.0f;
    return vec3(w.x + sx * u.x + sy * v.x, w.y + sx * u.y + sy * v.y, w.z + sx * u.z + sy * v.z);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_CAMERA_H
