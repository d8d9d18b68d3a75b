// sylva/render/metrics.hpp -- image differences between two rendered frames: PSNR, maximum
// and RMS absolute difference.
//
// Frames hold premultiplied RGBA. Each pixel is first composited over a background,
// c = rgb + (1 - alpha) * background, and clamped to [0, 1]; the metrics then compare the
// three colour channels of every pixel (alpha itself is not compared, it is in the colour
// through the background). PSNR = 10 log10(1 / MSE) with peak 1, +inf for identical images.
#ifndef SYLVA_RENDER_METRICS_HPP
#define SYLVA_RENDER_METRICS_HPP

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/render/particles.hpp"

namespace sylva {

/// How two frames differ over RGB composited over a background (see above).
struct ImageDifference {
    double psnr = std::numeric_limits<double>::infinity();  ///< dB, peak 1; +inf when identical
    double max_abs = 0.0;                                     ///< largest channel difference
    double rmse = 0.0;                                        ///< root mean squared difference
    std::size_t pixels_differing = 0;                         ///< pixels with any channel differing
};

/// Compares frames `a` and `b` of equal size over `background`. Throws sylva::Error when the
/// sizes differ, the frames are empty, or a pixel holds NaN or infinity.
inline ImageDifference compare_frames(const Frame& a, const Frame& b, vec3 background = vec3(0.0f)) {
    std::size_t n = std::size_t{a.width} * a.height;
    if (a.width != b.width || a.height != b.height || a.rgba.size() != n || b.rgba.size() != n)
        throw Error("compare_frames: frames of " + std::to_string(a.width) + "x" + std::to_string(a.height) + " and " +
                    std::to_string(b.width) + "x" + std::to_string(b.height) + " (or pixel counts) differ");
    if (n == 0) throw Error("compare_frames: empty frames");
    ImageDifference d;
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        bool differs = false;
        for (int k = 0; k < 4; ++k)
            if (!std::isfinite(a.rgba[i][k]) || !std::isfinite(b.rgba[i][k]))
                throw Error("compare_frames: pixel " + std::to_string(i) + " is not finite");
        for (int k = 0; k < 3; ++k) {
            double ca = std::clamp(double(a.rgba[i][k]) + (1.0 - double(a.rgba[i].a)) * background[k], 0.0, 1.0);
            double cb = std::clamp(double(b.rgba[i][k]) + (1.0 - double(b.rgba[i].a)) * background[k], 0.0, 1.0);
            double e = std::abs(ca - cb);
            d.max_abs = std::max(d.max_abs, e);
            sum += e * e;
            differs = differs || e > 0.0;
        }
        d.pixels_differing += differs ? 1u : 0u;
    }
    double mse = sum / double(3 * n);
    d.rmse = std::sqrt(mse);
    d.psnr = mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
    return d;
}

/// PSNR in dB of `b` against `a` over `background` (see compare_frames).
inline double psnr(const Frame& a, const Frame& b, vec3 background = vec3(0.0f)) {
    return compare_frames(a, b, background).psnr;
}

/// Largest absolute channel difference over `background` (see compare_frames).
inline double max_abs_diff(const Frame& a, const Frame& b, vec3 background = vec3(0.0f)) {
    return compare_frames(a, b, background).max_abs;
}

}  // namespace sylva

#endif  // SYLVA_RENDER_METRICS_HPP
