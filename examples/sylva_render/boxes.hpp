// sylva-render: the leaf boxes of a kd-tree drawn as lines over a rendering (--boxes): the 12
// edges of every box projected with the rendering's camera, pinhole or orthographic
// (sylva/shared/camera.h, inverted), and rasterised on the host.
#ifndef SYLVA_RENDER_BOXES_HPP
#define SYLVA_RENDER_BOXES_HPP

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include <sylva/core/aabb.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/particles.hpp>

namespace sylva_render {

/// Pixel position (x right, y down, pixel i covering [i, i + 1)) of world point p seen through
/// `cam` in a width x height image, given its depth along w is positive, with sx = 2 (x + 0.5) /
/// width - 1, sy = 1 - 2 (y + 0.5) / height and u, v, w orthogonal. The pinhole camera sends
/// pixel (x, y) along w + sx u + sy v: p - eye = a (w + sx u + sy v) gives sx and sy. The
/// orthographic one (`ortho`) starts it at eye + sx u + sy v along w: p - eye = sx u + sy v + a w.
inline sylva::vec2 project(const sylva::CameraFrame& cam, sylva::vec3 p, std::uint32_t width, std::uint32_t height,
                           bool ortho) {
    sylva::vec3 rel = p - cam.eye;
    float a = ortho ? 1.0f : glm::dot(rel, cam.w) / glm::dot(cam.w, cam.w);
    float sx = glm::dot(rel, cam.u) / (a * glm::dot(cam.u, cam.u));
    float sy = glm::dot(rel, cam.v) / (a * glm::dot(cam.v, cam.v));
    return {(sx + 1.0f) * 0.5f * static_cast<float>(width), (1.0f - sy) * 0.5f * static_cast<float>(height)};
}

/// Clips the segment a-b to the rectangle [lo, hi] (Liang-Barsky); false when nothing is left.
inline bool clip_segment(sylva::vec2& a, sylva::vec2& b, sylva::vec2 lo, sylva::vec2 hi) {
    float t0 = 0.0f, t1 = 1.0f;
    sylva::vec2 d = b - a;
    for (int k = 0; k < 2; ++k) {
        for (float sign : {-1.0f, 1.0f}) {
            float p = sign * d[k], q = sign > 0.0f ? hi[k] - a[k] : a[k] - lo[k];
            if (p == 0.0f) {
                if (q < 0.0f) return false;
                continue;
            }
            float r = q / p;
            if (p < 0.0f) t0 = std::max(t0, r);
            else t1 = std::min(t1, r);
        }
    }
    if (t0 > t1) return false;
    sylva::vec2 a0 = a;
    a = a0 + t0 * d;
    b = a0 + t1 * d;
    return true;
}

/// Draws one world-space segment over `f`: clipped to the camera's near side (the orthographic
/// camera's: its image plane through the eye, where its rays start), projected, clipped to the
/// image and rasterised one pixel per step along the longer axis; `colour` is straight RGBA,
/// composited over the pixels.
inline void draw_segment(sylva::Frame& f, const sylva::CameraFrame& cam, bool ortho, sylva::vec3 p, sylva::vec3 q,
                         sylva::vec4 colour) {
    sylva::vec3 w = glm::normalize(cam.w);
    float near = ortho ? 0.0f : 1e-4f * glm::length(cam.w), dp = glm::dot(p - cam.eye, w), dq = glm::dot(q - cam.eye, w);
    if (dp <= near && dq <= near) return;
    if (dp <= near) p = q + (p - q) * ((dq - near) / (dq - dp));
    if (dq <= near) q = p + (q - p) * ((dp - near) / (dp - dq));
    sylva::vec2 a = project(cam, p, f.width, f.height, ortho), b = project(cam, q, f.width, f.height, ortho);
    if (!clip_segment(a, b, sylva::vec2(0.0f), sylva::vec2(float(f.width) - 1e-3f, float(f.height) - 1e-3f))) return;
    int steps = static_cast<int>(std::ceil(std::max(std::abs(b.x - a.x), std::abs(b.y - a.y)))) + 1;
    for (int i = 0; i <= steps; ++i) {
        sylva::vec2 c = a + (b - a) * (static_cast<float>(i) / static_cast<float>(steps));
        auto x = static_cast<std::uint32_t>(c.x), y = static_cast<std::uint32_t>(c.y);
        if (x >= f.width || y >= f.height) continue;
        sylva::vec4& px = f.rgba[std::size_t{y} * f.width + x];
        px = sylva::vec4(sylva::vec3(colour) * colour.a, colour.a) + px * (1.0f - colour.a);  // premultiplied "over"
    }
}

/// Draws the 12 edges of every box over `f` in `colour` (straight RGBA), seen through `cam` as
/// a pinhole camera, or as an orthographic one when `ortho`.
inline void draw_boxes(sylva::Frame& f, const sylva::CameraFrame& cam, bool ortho, std::span<const sylva::Aabb> boxes,
                       sylva::vec4 colour) {
    for (const sylva::Aabb& b : boxes) {
        std::array<sylva::vec3, 8> v;
        for (int i = 0; i < 8; ++i)
            v[i] = sylva::vec3((i & 1) ? b.hi.x : b.lo.x, (i & 2) ? b.hi.y : b.lo.y, (i & 4) ? b.hi.z : b.lo.z);
        for (int i = 0; i < 8; ++i)
            for (int k : {1, 2, 4})
                if ((i & k) == 0) draw_segment(f, cam, ortho, v[i], v[i | k], colour);
    }
}

}  // namespace sylva_render

#endif
