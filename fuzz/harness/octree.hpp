// fuzz/harness/octree.hpp -- harness of the bricked octree (octree/validate.hpp, shared/octree_iter.h
// and shared/octree_dvr.h), with the promises of structures.hpp.
#ifndef SYLVA_FUZZ_HARNESS_OCTREE_HPP
#define SYLVA_FUZZ_HARNESS_OCTREE_HPP

#include <sylva/octree/validate.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/shared/octree_dvr.h>
#include <sylva/shared/octree_iter.h>
#include <sylva/volume/transfer_function.hpp>

#include "structures.hpp"

namespace sylva_fuzz {

/// Input: [index word count N, N index words, brick words...] of a bricked octree.
/// octree::validate(index, bricks), the walk to the leaves, and a DVR ray through octree_dvr.h.
inline int fuzz_octree(const std::uint8_t* data, std::size_t size) {
    using namespace sylva::shared;
    TwoParts p = two_parts(words_of(data, size));
    const std::vector<std::uint32_t>& words = p.first;
    const std::vector<std::uint32_t>& bricks = p.second;
    bool valid = !refuses([&] { sylva::octree::validate(words, bricks); });
    Words w{words.data(), words.size()}, b{bricks.data(), bricks.size()};
    uint wc = static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    uint bc = static_cast<uint>(std::min<std::size_t>(bricks.size(), 0xFFFFFFFFu));
    SylvaOctHeader h = sylva_oct_read_header(w, wc, bc);
    vec3 hi = h.origin + vec3(h.dims) * h.spacing;
    std::vector<sylva::Ray> rays = rays_over(h.origin, hi);
    for (const sylva::Ray& r : rays) {
        SylvaOctIter it{};
        sylva_oct_init(it, w, wc, bc, r.origin, r.direction, 0.0f, 1e30f, 0xFFFFFFFFu);
        std::uint32_t node, yielded = 0;
        float t0, t1;
        while (sylva_oct_next(it, w, node, t0, t1)) {
            SYLVA_FUZZ_CHECK(node < h.node_count, "a node outside the index");
            SYLVA_FUZZ_CHECK(++yielded <= it.step_limit, "more leaves than the step limit");
        }
        SYLVA_FUZZ_CHECK(it.status != SYLVA_ITER_RUNNING, "a walk stopped while running");
        if (valid) SYLVA_FUZZ_CHECK(it.status == SYLVA_ITER_DONE, "an accepted octree walked into an error");
    }
    // DVR through the shared integrator, on accepted octrees of modest size (the lattice has
    // 1024 steps along the longest axis whatever the size; big extents only cost time).
    if (!valid || h.dims.x > 1024u || h.dims.y > 1024u || h.dims.z > 1024u) return 0;
    sylva::VolumeRenderParams rp;
    rp.tf = sylva::volume::TransferFunction::ramp(0.2f, 0.8f, sylva::vec4(1.0f, 0.5f, 0.2f, 0.7f)).packed_rgba8();
    sylva::OctreeView view{words, bricks};
    std::vector<std::uint32_t> params;
    if (refuses([&] { params = sylva::octree_dvr_params(view, rp); })) return 0;
    std::vector<std::uint32_t> tfsum = sylva::tf_opacity_prefix(rp.tf);
    Words pw{params.data(), params.size()}, tw{rp.tf.data(), rp.tf.size()}, sw{tfsum.data(), tfsum.size()};
    SylvaDvrParams sp = sylva_dvr_params(pw);
    for (const sylva::Ray& r : rays) {
        std::uint32_t steps, visits, status;
        sylva::vec4 c = sylva_oct_dvr_ray(w, b, tw, sw, sp, h, 0xFFFFFFFFu, r.origin, r.direction, 0.0f, sylva_inf(), steps,
                                          visits, status);
        SYLVA_FUZZ_CHECK(status != SYLVA_ITER_ERROR, "an accepted octree's DVR ray walked into an error"); // RUNNING: early termination
        SYLVA_FUZZ_CHECK(c.a >= 0.0f && c.a <= 1.0f + 1e-5f, "a DVR opacity outside [0, 1]");
    }
    return 0;
}

}  // namespace sylva_fuzz

#endif  // SYLVA_FUZZ_HARNESS_OCTREE_HPP
