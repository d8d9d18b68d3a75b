// sylva_gpu_probe: whether this machine has a Vulkan GPU for the tests labelled gpu. Exit 0 and
// the device's description when SYLVA_VULKAN_DEVICE=gpu would pick one; 77 (ctest: skipped) with
// the reason when there is none (no GPU, or no Vulkan at all).
#include <cstdio>
#include <exception>

#include <sylva/vulkan/context.hpp>

int main() {
    try {
        const sylva::vk::Context ctx = sylva::vk::Context::create("gpu");
        std::printf("GPU: %s\n", ctx.describe().c_str());
        return 0;
    } catch (const std::exception& e) {
        std::printf("SKIPPED: no Vulkan GPU on this machine, so the tests labelled gpu do not run (%s)\n", e.what());
        return 77;
    }
}
