// sylva/render/image.hpp -- writing frames and traversal-cost heat maps through OpenImageIO
// (link the `sylva_image` target). PNG gets 8-bit sRGB over a background; EXR keeps linear
// float RGBA (premultiplied).
#ifndef SYLVA_RENDER_IMAGE_HPP
#define SYLVA_RENDER_IMAGE_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "sylva/core/error.hpp"
#include "sylva/render/particles.hpp"

namespace sylva {

namespace detail {
inline bool ends_with(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && std::equal(tail.rbegin(), tail.rend(), s.rbegin(),
                                                 [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}
inline float to_srgb(float c) {
    c = std::clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}
inline void write_pixels(const std::string& path, std::uint32_t w, std::uint32_t h, int channels,
                         OIIO::TypeDesc type, const void* data) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) throw Error("cannot write " + path + ": no image format for this extension");
    OIIO::ImageSpec spec(static_cast<int>(w), static_cast<int>(h), channels, type);
    if (!out->open(path, spec) || !out->write_image(type, data) || !out->close())
        throw Error("cannot write " + path + ": " + out->geterror());
}
}  // namespace detail

/// Writes a frame: .exr as linear premultiplied float RGBA, anything else (PNG) as 8-bit sRGB
/// RGB composited over `background`. Throws sylva::Error when the file cannot be written.
inline void write_frame(const std::string& path, const Frame& f, vec3 background = vec3(0.0f)) {
    if (detail::ends_with(path, ".exr")) {
        detail::write_pixels(path, f.width, f.height, 4, OIIO::TypeDesc::FLOAT, f.rgba.data());
        return;
    }
    std::vector<std::uint8_t> px(f.rgba.size() * 3);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        vec3 c = vec3(f.rgba[i]) + (1.0f - f.rgba[i].a) * background;
        for (int k = 0; k < 3; ++k)
            px[i * 3 + k] = static_cast<std::uint8_t>(std::lround(detail::to_srgb(c[k]) * 255.0f));
    }
    detail::write_pixels(path, f.width, f.height, 3, OIIO::TypeDesc::UINT8, px.data());
}

/// Colour of t in [0, 1] on a dark-blue to yellow ramp (perceptually ordered).
inline vec3 heat_color(float t) {
    const vec3 stops[5] = {{0.05f, 0.03f, 0.2f}, {0.35f, 0.05f, 0.55f}, {0.8f, 0.2f, 0.35f},
                           {0.98f, 0.55f, 0.1f}, {0.99f, 0.95f, 0.6f}};
    t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
    int i = std::min(static_cast<int>(t), 3);
    return glm::mix(stops[i], stops[i + 1], t - static_cast<float>(i));
}

/// Writes the per-pixel iterator steps as a heat map scaled to the frame's maximum (errors,
/// 0xFFFFFFFF, show as pure red). Returns the maximum step count.
inline std::uint32_t write_heatmap(const std::string& path, const Frame& f) {
    std::uint32_t peak = 1;
    for (std::uint32_t s : f.steps)
        if (s != 0xFFFFFFFFu) peak = std::max(peak, s);
    std::vector<std::uint8_t> px(f.steps.size() * 3);
    for (std::size_t i = 0; i < f.steps.size(); ++i) {
        vec3 c = f.steps[i] == 0xFFFFFFFFu ? vec3(1.0f, 0.0f, 0.0f)
                                           : heat_color(static_cast<float>(f.steps[i]) / static_cast<float>(peak));
        for (int k = 0; k < 3; ++k) px[i * 3 + k] = static_cast<std::uint8_t>(std::lround(c[k] * 255.0f));
    }
    detail::write_pixels(path, f.width, f.height, 3, OIIO::TypeDesc::UINT8, px.data());
    return peak;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_IMAGE_HPP
