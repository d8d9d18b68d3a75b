// sylva-render, particle input: the camera and the render settings every particle scene uses
// (BIH, kd-tree, element octree, exact order, animation), so that --view, --camera and
// --alpha-stop mean the same through each.
#ifndef SYLVA_RENDER_PARTICLE_VIEW_HPP
#define SYLVA_RENDER_PARTICLE_VIEW_HPP

#include <span>

#include <sylva/core/aabb.hpp>
#include <sylva/elements/sphere.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/particles.hpp>

#include "options.hpp"

namespace sylva_render {

/// The camera framing `box` from --view (default (0.4, 0.7, 1)): a pinhole, or with --camera
/// ortho the same eye and view direction with a view rectangle as high as the box's bounding
/// sphere (rays start on the eye's plane and run along the view direction).
inline sylva::CameraFrame particle_camera(const Options& o, const sylva::Aabb& box) {
    using namespace sylva;
    vec3 from = o.view ? vec3((*o.view)[0], (*o.view)[1], (*o.view)[2]) : vec3(0.4f, 0.7f, 1.0f);
    Camera cam = Camera::framing(box, from);
    if (o.camera == "ortho") return cam.ortho_frame(o.width, o.height, 0.5f * glm::length(box.extent()));
    return cam.frame(o.width, o.height);
}

/// particle_camera over the particles' bounds.
inline sylva::CameraFrame particle_camera(const Options& o, std::span<const sylva::Sphere> spheres) {
    sylva::Aabb box;
    for (const sylva::Sphere& p : spheres) box.extend(sylva::bounds_of(p));
    return particle_camera(o, box);
}

/// --alpha-stop and the ray source of --camera (pinhole or orthographic) for the particle
/// renderers (sylva/render/particles.hpp: ParticleRenderConfig).
inline sylva::ParticleRenderConfig particle_config(const Options& o) {
    sylva::ParticleRenderConfig rc;
    rc.alpha_stop = o.alpha_stop;
    rc.rays.source = o.camera == "ortho" ? sylva::RaySource::Ortho : sylva::RaySource::Pinhole;
    return rc;
}

}  // namespace sylva_render

#endif  // SYLVA_RENDER_PARTICLE_VIEW_HPP
