// sylva-render --boxes (examples/sylva_render/boxes.hpp): a world point projects to the pixel
// whose camera ray passes through it, for the pinhole and the orthographic camera
// (sylva/shared/camera.h is the independent reference: the rays the renderers trace).
#include <catch2/catch.hpp>

#include <random>

#include <sylva/render/camera.hpp>
#include <sylva/shared/camera.h>

#include "sylva_render/boxes.hpp"

using namespace sylva;

TEST_CASE("sylva-render boxes: the projection inverts the pinhole and the orthographic camera rays", "[render][boxes]") {
    const std::uint32_t w = 97, h = 61;
    Aabb box{vec3(-1.0f, -2.0f, 0.5f), vec3(3.0f, 1.0f, 2.5f)};
    Camera cam = Camera::framing(box, vec3(0.4f, 0.3f, 1.0f));
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (bool ortho : {false, true}) {
        CameraFrame f = ortho ? cam.ortho_frame(w, h, 2.5f) : cam.frame(w, h);
        std::uint32_t source = ortho ? SYLVA_RAYS_ORTHO : SYLVA_RAYS_PINHOLE;
        for (int n = 0; n < 200; ++n) {
            auto x = static_cast<std::uint32_t>(u(rng) * w), y = static_cast<std::uint32_t>(u(rng) * h);
            shared::SylvaRay r = shared::sylva_camera_ray(source, f.eye, f.w, f.u, f.v, x, y, w, h);
            vec3 p = r.origin + (0.5f + 3.0f * u(rng)) * r.dir;  // a point on pixel (x, y)'s ray, in front
            vec2 px = sylva_render::project(f, p, w, h, ortho);
            INFO("ortho " << ortho << " pixel " << x << "," << y << " projected " << px.x << "," << px.y);
            CHECK(px.x == Approx(x + 0.5f).margin(1e-3));  // the centre of the pixel
            CHECK(px.y == Approx(y + 0.5f).margin(1e-3));
        }
    }
    // The orthographic camera draws nothing behind its image plane (its rays start there), the
    // pinhole camera nothing behind its near plane; a segment in front is drawn.
    CameraFrame f = cam.ortho_frame(w, h, 2.5f);
    Frame img{w, h, std::vector<vec4>(std::size_t{w} * h, vec4(0.0f)), std::vector<std::uint32_t>(std::size_t{w} * h), 0.0};
    vec3 behind = f.eye - glm::normalize(f.w);
    sylva_render::draw_segment(img, f, true, behind, behind + 0.5f * f.u, vec4(1.0f));
    std::size_t lit = 0;
    for (const vec4& c : img.rgba) lit += c.w > 0.0f;
    CHECK(lit == 0);
    vec3 front = f.eye + glm::normalize(f.w);
    sylva_render::draw_segment(img, f, true, front, front + 0.5f * f.u, vec4(1.0f));
    for (const vec4& c : img.rgba) lit += c.w > 0.0f;
    CHECK(lit >= w / 4 - 1);  // half of the half-width: a quarter of the image's width
}
