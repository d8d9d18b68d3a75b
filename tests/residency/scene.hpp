// The residency tests' scene: a test volume's octree, a view and a transfer function, the
// in-core reference render of a cut, and the progressive out-of-core loop.
#ifndef SYLVA_TESTS_RESIDENCY_SCENE_HPP
#define SYLVA_TESTS_RESIDENCY_SCENE_HPP

#include <cstdint>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/residency.hpp>
#include <sylva/render/octree_volume.hpp>

#include "reference.hpp"

namespace residency_test {

using namespace sylva;

inline VolumeRenderParams params_for(const volume::DensityGrid& g, vec3 from, std::uint32_t w = 64, std::uint32_t h = 48) {
    VolumeRenderParams p;
    p.width = w;
    p.height = h;
    p.camera = Camera::framing(g.world_box(), from, 35.0f).frame(w, h);
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i)
        p.tf[i] = (60 + i * 3 / 4) | ((230 - i / 2) << 8) | (100u << 16) | ((i < 90 ? 0u : (i - 90) / 2) << 24);
    p.shading = true;
    return p;
}

/// The in-core octree's image through `cut` (all bricks resident).
inline Frame in_core(const octree::Tree& t, const octree::Cut& cut, const VolumeRenderParams& p, ThreadPool& pool) {
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::apply_cut(words, cut);
    return render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);
}

/// Bit-exact equality of two frames' colours.
inline bool same_pixels(const Frame& a, const Frame& b) {
    if (a.rgba.size() != b.rgba.size()) return false;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c)
            if (std::bit_cast<std::uint32_t>(a.rgba[i][c]) != std::bit_cast<std::uint32_t>(b.rgba[i][c])) return false;
    return true;
}

/// One out-of-core frame: update, then render the host pool with the feedback bound.
template <class Res>
Frame ooc_frame(Res& res, const octree::HostBrickPool& pool, const VolumeRenderParams& p, const OctreeTerminal& term,
                ThreadPool& exec) {
    const octree::ResidencyFrame& f = res.update(octree::cut_view(p.camera, p.width, p.height), term);
    return render_octree_dvr_cpu(OctreeView{f.words, pool.words, 0xFFFFFFFFu, res.feedback()}, p, exec);
}

}  // namespace residency_test

#endif
