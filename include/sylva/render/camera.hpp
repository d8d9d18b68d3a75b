// sylva/render/camera.hpp -- a look-at camera and its 12-float frame for the shaders (pinhole, or
// orthographic with ortho_frame; the ray generators are sylva/shared/camera.h's).
#ifndef SYLVA_RENDER_CAMERA_HPP
#define SYLVA_RENDER_CAMERA_HPP

#include <array>
#include <cmath>

#include "sylva/core/aabb.hpp"
#include "sylva/core/ray.hpp"
#include "sylva/shared/camera.h"

namespace sylva {

/// Eye, forward w, right u and up v as sylva/shared/camera.h expects them.
struct CameraFrame {
    vec3 eye, w, u, v;
    /// The 12 floats pushed to shaders.
    [[nodiscard]] std::array<float, 12> floats() const {
        return {eye.x, eye.y, eye.z, w.x, w.y, w.z, u.x, u.y, u.z, v.x, v.y, v.z};
    }
    /// The ray through the centre of pixel (x, y) (same arithmetic as the shaders).
    [[nodiscard]] Ray ray(std::uint32_t x, std::uint32_t y, std::uint32_t width, std::uint32_t height) const {
        return {eye, shared::sylva_camera_dir(w, u, v, x, y, width, height)};
    }
};

/// A look-at camera with a vertical field of view in degrees.
struct Camera {
    vec3 eye{0.0f, 0.0f, 3.0f};
    vec3 target{0.0f};
    vec3 up{0.0f, 1.0f, 0.0f};
    float fov_y_deg = 40.0f;

    [[nodiscard]] CameraFrame frame(std::uint32_t width, std::uint32_t height) const {
        vec3 w = glm::normalize(target - eye);
        vec3 u = glm::normalize(glm::cross(w, up));
        vec3 v = glm::cross(u, w);
        float half_h = std::tan(glm::radians(fov_y_deg) * 0.5f);
        float half_w = half_h * static_cast<float>(width) / static_cast<float>(height);
        return {eye, w, u * half_w, v * half_h};
    }

    /// The frame of an orthographic view (RaySource::Ortho, sylva/shared/camera.h): w the unit
    /// view direction, u and v the half-width and half-height of the view rectangle in world
    /// units (half_height high, width / height as wide), centred on the eye.
    [[nodiscard]] CameraFrame ortho_frame(std::uint32_t width, std::uint32_t height, float half_height) const {
        vec3 w = glm::normalize(target - eye);
        vec3 u = glm::normalize(glm::cross(w, up));
        vec3 v = glm::cross(u, w);
        float half_w = half_height * static_cast<float>(width) / static_cast<float>(height);
        return {eye, w, u * half_w, v * half_height};
    }

    /// A camera looking at `box` from direction `from` so that the whole box is in view.
    static Camera framing(const Aabb& box, vec3 from = {0.4f, 0.3f, 1.0f}, float fov_y_deg = 40.0f) {
        vec3 c = box.center();
        float radius = 0.5f * glm::length(box.extent());
        float dist = radius / std::sin(glm::radians(fov_y_deg) * 0.5f);
        return {c + glm::normalize(from) * dist, c, {0.0f, 1.0f, 0.0f}, fov_y_deg};
    }
};

}  // namespace sylva

#endif  // SYLVA_RENDER_CAMERA_HPP
