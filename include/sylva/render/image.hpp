// sylva/render/image.hpp -- writing frames and traversal-cost heat maps through OpenImageIO
// (link the `sylva_image` target). PNG gets 8-bit sRGB over a background; EXR keeps linear
// float RGBA (premultiplied). Without OpenImageIO (SYLVA_HAVE_OIIO=0, as the `sylva_image`
// target defines when the package is missing, or no header to include) only binary PPM (.ppm,
// 8-bit sRGB) and PFM (.pfm, linear float RGB, premultiplied, bottom row first) are written;
// any other extension is an error naming the missing library.
#ifndef SYLVA_RENDER_IMAGE_HPP
#define SYLVA_RENDER_IMAGE_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#ifndef SYLVA_HAVE_OIIO
#if __has_include(<OpenImageIO/imageio.h>)
#define SYLVA_HAVE_OIIO 1
#else
#define SYLVA_HAVE_OIIO 0
#endif
#endif
#if SYLVA_HAVE_OIIO
#include <OpenImageIO/imageio.h>
#else
#include <cstdio>
#include <memory>
#endif

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
/// What a pixel channel holds: 8-bit sRGB or linear float.
enum class PixelType { UInt8, Float };

#if SYLVA_HAVE_OIIO
inline void write_pixels(const std::string& path, std::uint32_t w, std::uint32_t h, int channels, PixelType type,
                         const void* data) {
    OIIO::TypeDesc desc = type == PixelType::Float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
    auto out = OIIO::ImageOutput::create(path);
    if (!out) throw Error("cannot write " + path + ": no image format for this extension");
    OIIO::ImageSpec spec(static_cast<int>(w), static_cast<int>(h), channels, desc);
    if (!out->open(path, spec) || !out->write_image(desc, data) || !out->close())
        throw Error("cannot write " + path + ": " + out->geterror());
}
#else
/// Without OpenImageIO: binary PPM for 8-bit RGB, PFM (RGB, little endian) for float RGB(A).
inline void write_pixels(const std::string& path, std::uint32_t w, std::uint32_t h, int channels, PixelType type,
                         const void* data) {
    const bool ppm = ends_with(path, ".ppm"), pfm = ends_with(path, ".pfm");
    if ((type == PixelType::UInt8 && !ppm) || (type == PixelType::Float && !pfm) || channels < 3)
        throw Error("cannot write " + path + ": built without OpenImageIO (libopenimageio-dev), which writes PNG and "
                    "EXR; name a ." + std::string(type == PixelType::Float ? "pfm" : "ppm") + " file instead");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!file) throw Error("cannot write " + path + ": cannot open the file");
    const std::string header = std::string(ppm ? "P6" : "PF") + "\n" + std::to_string(w) + " " + std::to_string(h) +
                               (ppm ? "\n255\n" : "\n-1.0\n");
    bool ok = std::fwrite(header.data(), 1, header.size(), file.get()) == header.size();
    const std::size_t cs = static_cast<std::size_t>(channels);
    for (std::uint32_t row = 0; ok && row < h; ++row) {
        const std::size_t y = ppm ? row : h - 1 - row;  // PFM stores the bottom row first
        for (std::size_t x = 0; ok && x < w; ++x) {
            const std::size_t px = (y * w + x) * cs;
            ok = ppm ? std::fwrite(static_cast<const std::uint8_t*>(data) + px, 1, 3, file.get()) == 3
                     : std::fwrite(static_cast<const float*>(data) + px, sizeof(float), 3, file.get()) == 3;
        }
    }
    if (!ok || std::fclose(file.release()) != 0) throw Error("cannot write " + path + ": write failed");
}
#endif
}  // namespace detail

/// Writes a frame: .exr (.pfm without OpenImageIO) as linear premultiplied float RGBA, anything
/// else (PNG; .ppm without OpenImageIO) as 8-bit sRGB RGB composited over `background`. Throws
/// sylva::Error when the file cannot be written.
inline void write_frame(const std::string& path, const Frame& f, vec3 background = vec3(0.0f)) {
    if (detail::ends_with(path, ".exr") || detail::ends_with(path, ".pfm")) {
        detail::write_pixels(path, f.width, f.height, 4, detail::PixelType::Float, f.rgba.data());
        return;
    }
    std::vector<std::uint8_t> px(f.rgba.size() * 3);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        vec3 c = vec3(f.rgba[i]) + (1.0f - f.rgba[i].a) * background;
        for (int k = 0; k < 3; ++k)
            px[i * 3 + k] = static_cast<std::uint8_t>(std::lround(detail::to_srgb(c[k]) * 255.0f));
    }
    detail::write_pixels(path, f.width, f.height, 3, detail::PixelType::UInt8, px.data());
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
    detail::write_pixels(path, f.width, f.height, 3, detail::PixelType::UInt8, px.data());
    return peak;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_IMAGE_HPP
