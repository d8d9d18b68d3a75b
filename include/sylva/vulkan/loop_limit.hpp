// sylva/vulkan/loop_limit.hpp -- whether a Vulkan device cuts long shader loops short.
//
// Lavapipe up to Mesa 22.3 (Debian 12's own) ends every loop of a SIMD batch of 8 invocations
// once 65,535 loop iterations have run in the batch (docs/DESIGN.md, "Vulkan runner"); lavapipe
// 25.0 (bookworm-backports) and GPUs have no such limiter. The element image kernel pauses rays
// at a loop budget only where loops are cut (vk::ElementKernel::loop_budget), and tests expect
// marked pixels only there. Known by running shaders/loop_limit_probe.comp once per device (a
// loop of 200,000 iterations, then shared/loop_cut.glsl's check); the answer is kept with the
// device, so every Context on it and every later call reuse it.
#ifndef SYLVA_VULKAN_LOOP_LIMIT_HPP
#define SYLVA_VULKAN_LOOP_LIMIT_HPP

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "sylva/spirv/loop_limit_probe.h"
#include "sylva/vulkan/runner.hpp"

namespace sylva::vk {

/// Iterations of the probe's loop: well past lavapipe 22.3's 65,535 a batch.
inline constexpr std::uint32_t kLoopLimitProbeTrips = 200000;

/// True when `context`'s device cuts shader loops short after a fixed number of iterations
/// (lavapipe up to Mesa 22.3). Probed with one dispatch of 64 invocations on first use, then
/// cached with the device.
inline bool loops_limited(Context& context) {
    std::atomic<int>& known = context.shared_device()->loops_limited;
    if (int k = known.load(); k >= 0) return k == 1;
    constexpr std::uint32_t kInvocations = 64;
    std::vector<std::uint32_t> in(kInvocations);  // any words: the loop adds them up
    for (std::uint32_t i = 0; i < in.size(); ++i) in[i] = i * 2654435761u;
    Buffer in_buf(context, in.size() * 4), out_buf(context, kInvocations * 3 * 4);
    in_buf.upload(in);
    Kernel kernel(context, spirv::loop_limit_probe, 2, 4);
    const std::uint32_t trips = kLoopLimitProbeTrips;
    std::array<Buffer*, 2> bind{&in_buf, &out_buf};
    context.dispatch(kernel, bind, &trips, sizeof trips, 1);
    std::vector<std::uint32_t> out(kInvocations * 3);
    out_buf.download(out);
    bool cut = false;
    for (std::uint32_t i = 0; i < kInvocations; ++i) cut = cut || out[3 * i + 1] != 0;
    known.store(cut ? 1 : 0);
    return cut;
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_LOOP_LIMIT_HPP
