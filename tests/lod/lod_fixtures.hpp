// Shared fixtures of the LoD tests: analytic and synthetic density grids, the real volumes of
// ../shared/data, and brute-force walks over a built tree.
#ifndef SYLVA_TESTS_LOD_FIXTURES_HPP
#define SYLVA_TESTS_LOD_FIXTURES_HPP

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <sylva/bih/tree.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/read_raw.hpp>

#include "../missing_data.hpp"

namespace sylva::lodtest {

/// Quantises to 8 bits like the real volumes, so uniform regions are exactly uniform.
inline float q8(float d) { return std::round(std::clamp(d, 0.0f, 1.0f) * 255.0f) / 255.0f; }

/// A synthetic 8-bit-like volume: a solid block of constant density (merges into big LoD
/// leaves), two smooth Gaussian blobs (gradients, varying density), a thin shell, and noise
/// below and around the 0.1 threshold.
inline volume::DensityGrid synthetic_grid(volume::Dims dims, vec3 spacing, std::uint32_t seed) {
    volume::DensityGrid g{dims, spacing, std::vector<float>(volume::voxel_count(dims), 0.0f)};
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> noise(0.0f, 0.12f);
    vec3 n(dims);
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) {
                vec3 p = (vec3(x, y, z) + 0.5f) / n;  // [0, 1]^3
                float d = noise(rng);
                if (p.x > 0.1f && p.x < 0.45f && p.y > 0.15f && p.y < 0.6f && p.z > 0.2f && p.z < 0.7f) d = 0.6f;
                d += 0.8f * std::exp(-glm::dot(p - vec3(0.7f, 0.6f, 0.5f), p - vec3(0.7f, 0.6f, 0.5f)) / 0.02f);
                d += 0.5f * std::exp(-glm::dot(p - vec3(0.3f, 0.8f, 0.3f), p - vec3(0.3f, 0.8f, 0.3f)) / 0.01f);
                float r = glm::length(p - vec3(0.5f));
                if (std::fabs(r - 0.42f) < 0.03f) d = std::max(d, 0.35f);
                g.values[volume::voxel_index(dims, x, y, z)] = q8(d);
            }
    return g;
}

/// Elements of the subtree of `node` (brute force over the tree's links).
inline std::vector<std::uint32_t> subtree_elements(const bih::Tree& t, std::uint32_t node) {
    std::vector<std::uint32_t> out, stack{node};
    while (!stack.empty()) {
        const bih::Node& n = t.nodes[stack.back()];
        stack.pop_back();
        if (n.leaf()) {
            for (std::uint32_t k = 0; k < n.count; ++k) out.push_back(t.order[n.first + k]);
            continue;
        }
        for (int c = 0; c < (n.single ? 1 : 2); ++c)
            if (n.child[c] != bih::kNoChild) stack.push_back(n.child[c]);
    }
    return out;
}

/// Depth of every node (root = 0), from the links.
inline std::vector<std::uint32_t> node_depths(const bih::Tree& t) {
    std::vector<std::uint32_t> depth(t.nodes.size(), 0), stack{0u};
    while (!stack.empty()) {
        std::uint32_t i = stack.back();
        stack.pop_back();
        const bih::Node& n = t.nodes[i];
        if (n.leaf()) continue;
        for (int c = 0; c < (n.single ? 1 : 2); ++c)
            if (n.child[c] != bih::kNoChild) {
                depth[n.child[c]] = depth[i] + 1;
                stack.push_back(n.child[c]);
            }
    }
    return depth;
}

/// Path of a data file in ../shared/data.
inline std::string data_path(const std::string& name) { return (testdata::dir() / name).string(); }

/// An 8-bit raw volume from ../shared/data, normalised (value / 255). When the file is missing
/// the test FAILS naming the path, or with SYLVA_ALLOW_MISSING_DATA=1 ends as skipped
/// (tests/missing_data.hpp); the optional is never empty.
inline std::optional<volume::DensityGrid> load_u8(const std::string& name, volume::Dims dims, vec3 spacing) {
    std::string path = data_path(name);
    if (!std::filesystem::exists(path)) testdata::missing(path);
    // Normalised by 255 as Kinkelin's tables are (the type range, whatever the data's max).
    return volume::normalize(volume::read_raw(path, {dims, volume::ScalarType::U8, spacing}, volume::ValueRange::of_type()));
}

}  // namespace sylva::lodtest

#endif  // SYLVA_TESTS_LOD_FIXTURES_HPP
