// Image comparisons the octree's render tests share: RGBA8 packing of TF entries, pixels whose
// bits differ, the largest channel difference and the lattice samples of a frame.
#ifndef SYLVA_TESTS_OCTREE_FRAMES_HPP
#define SYLVA_TESTS_OCTREE_FRAMES_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include <sylva/render/volume.hpp>

namespace octree_test {

/// A TF entry: straight RGBA in [0, 1] as RGBA8 (R in bits 0-7).
inline std::uint32_t rgba8(float r, float g, float b, float a) {
    auto q = [](float v) { return std::uint32_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
    return q(r) | q(g) << 8 | q(b) << 16 | q(a) << 24;
}

/// Pixels whose RGBA bits differ.
inline std::size_t differing(const sylva::Frame& a, const sylva::Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c)
            if (std::bit_cast<std::uint32_t>(a.rgba[i][c]) != std::bit_cast<std::uint32_t>(b.rgba[i][c])) {
                ++n;
                break;
            }
    return n;
}

/// The largest difference of any channel of any pixel.
inline double max_diff(const sylva::Frame& a, const sylva::Frame& b) {
    double m = 0.0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) m = std::max(m, double(std::abs(a.rgba[i][c] - b.rgba[i][c])));
    return m;
}

/// Lattice samples of all pixels.
inline std::uint64_t total_samples(const sylva::Frame& f) {
    std::uint64_t s = 0;
    for (std::uint32_t v : f.steps) s += v;
    return s;
}

}  // namespace octree_test

#endif  // SYLVA_TESTS_OCTREE_FRAMES_HPP
