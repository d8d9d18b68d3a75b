// sylva/vulkan/runner.hpp -- the compute runner: include this one header.
//
//   auto context = sylva::vk::Context::create();             // SYLVA_VULKAN_DEVICE picks the device
//   sylva::vk::Kernel kernel(context, sylva::spirv::my_shader, 2, sizeof(Push));
//   sylva::vk::Buffer in(context, bytes), out(context, bytes);
//   in.upload(words);
//   std::array<sylva::vk::Buffer*, 2> buffers{&in, &out};
//   double ms = context.dispatch(kernel, buffers, &push, sizeof push, sylva::vk::groups_for(n, 64));
//   out.download(result);
//
// A user's own shader over an encoding and the user's elements (any encoding uploaded with
// split_words binds as four consecutive buffers, see sylva/shared/split_words.glsl):
//
//   sylva::vk::SplitWords tree = sylva::vk::split_words(context, encoded_words);
//   sylva::vk::Buffer elements = sylva::vk::upload_buffer(context, my_records);
//   sylva::vk::Bindings bindings;
//   bindings.add(tree).add(elements).add(out);           // bindings 0-3, 4, 5
//   sylva::vk::Kernel kernel(context, sylva::spirv::my_shader, bindings.size(), sizeof(Push),
//                            std::array<std::uint32_t, 2>{tree.shift, depth});
//   context.dispatch(kernel, bindings.list(), &push, sizeof push, sylva::vk::groups_for(n, 64));
#ifndef SYLVA_VULKAN_RUNNER_HPP
#define SYLVA_VULKAN_RUNNER_HPP

#include <vulkan/vulkan.h>

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/buffer.hpp"
#include "sylva/vulkan/context.hpp"
#include "sylva/vulkan/detail/device.hpp"
#include "sylva/vulkan/kernel.hpp"
#include "sylva/vulkan/split_words.hpp"

namespace sylva::vk {

/// The number of workgroups of `group_size` invocations that cover `items` items (rounded up).
/// Throws sylva::Error when that does not fit in 32 bits.
inline std::uint32_t groups_for(std::size_t items, std::uint32_t group_size) {
    if (group_size == 0) throw Error("groups_for: group size 0");
    const std::size_t groups = items / group_size + (items % group_size != 0 ? 1 : 0);
    if (groups > UINT32_MAX) throw Error("groups_for: " + std::to_string(items) + " items need too many groups");
    return static_cast<std::uint32_t>(groups);
}

/// The storage buffers of one dispatch in binding order: add() appends a buffer (the next binding)
/// or all parts of a split word array (the next four, as SYLVA_SPLIT_WORDS declares them). Holds
/// pointers: the buffers must outlive the dispatch.
class Bindings {
public:
    /// Binds `buffer` at the next binding.
    Bindings& add(Buffer& buffer) {
        buffers_.push_back(&buffer);
        return *this;
    }
    /// Binds the parts of `words` at the next words.parts.size() bindings.
    Bindings& add(SplitWords& words) {
        for (Buffer& part : words.parts) buffers_.push_back(&part);
        return *this;
    }
    /// How many bindings so far: the kernel's storage_buffer_count.
    [[nodiscard]] std::uint32_t size() const noexcept { return static_cast<std::uint32_t>(buffers_.size()); }
    /// The list for Context::dispatch.
    [[nodiscard]] std::span<Buffer* const> list() const noexcept { return buffers_; }

private:
    std::vector<Buffer*> buffers_;
};

namespace detail {

/// Throws sylva::Error unless the dispatch arguments match the kernel and the device.
inline void check_dispatch(const Device& d, const Kernel& kernel, std::span<Buffer* const> buffers, const void* push,
                           std::size_t push_bytes, const std::array<std::uint32_t, 3>& groups) {
    if (kernel.device() != &d) throw Error("dispatch: the kernel was made on a different Context");
    if (buffers.size() != kernel.storage_buffer_count()) {
        throw Error("dispatch: " + std::to_string(buffers.size()) + " buffers given, the kernel binds " +
                    std::to_string(kernel.storage_buffer_count()));
    }
    if (push_bytes != kernel.push_constant_bytes() || (push_bytes > 0 && push == nullptr)) {
        throw Error("dispatch: " + std::to_string(push_bytes) + " bytes of push constants given, the kernel takes " +
                    std::to_string(kernel.push_constant_bytes()));
    }
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        if (buffers[i] == nullptr || buffers[i]->device() != &d) {
            throw Error("dispatch: buffer " + std::to_string(i) + " is null or from a different Context");
        }
        if (buffers[i]->bound_bytes() > d.properties.limits.maxStorageBufferRange) {
            throw Error("dispatch: buffer " + std::to_string(i) + " of " + std::to_string(buffers[i]->bound_bytes()) +
                        " bytes exceeds maxStorageBufferRange (" +
                        std::to_string(d.properties.limits.maxStorageBufferRange) + "); use split_words");
        }
    }
    for (int axis = 0; axis < 3; ++axis) {
        if (groups[axis] > d.properties.limits.maxComputeWorkGroupCount[axis]) {
            throw Error("dispatch: " + std::to_string(groups[axis]) + " groups on axis " + std::to_string(axis) +
                        " exceed the device limit of " +
                        std::to_string(d.properties.limits.maxComputeWorkGroupCount[axis]));
        }
    }
}

/// Points binding i of the kernel's descriptor set at buffers[i]. The caller holds submit_mutex.
inline void bind_buffers(const Device& d, const Kernel& kernel, std::span<Buffer* const> buffers) {
    if (buffers.empty()) return;
    std::vector<VkDescriptorBufferInfo> infos(buffers.size());
    std::vector<VkWriteDescriptorSet> writes(buffers.size());
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        infos[i] = VkDescriptorBufferInfo{buffers[i]->handle(), 0, VK_WHOLE_SIZE};
        writes[i] = make_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
        writes[i].dstSet = kernel.descriptor_set();
        writes[i].dstBinding = static_cast<std::uint32_t>(i);
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(d.device, static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

/// Records barrier, timestamps around the dispatch, and a closing barrier for host reads.
inline void record_dispatch(const Device& d, VkCommandBuffer cmd, const Kernel& kernel, const void* push,
                            std::size_t push_bytes, const std::array<std::uint32_t, 3>& groups) {
    full_barrier(cmd);
    if (d.timestamp_pool != VK_NULL_HANDLE) {
        vkCmdResetQueryPool(cmd, d.timestamp_pool, 0, 2);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, d.timestamp_pool, 0);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline());
    if (kernel.storage_buffer_count() > 0) {
        VkDescriptorSet set = kernel.descriptor_set();
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline_layout(), 0, 1, &set, 0, nullptr);
    }
    if (push_bytes > 0) {
        vkCmdPushConstants(cmd, kernel.pipeline_layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0,
                           static_cast<std::uint32_t>(push_bytes), push);
    }
    vkCmdDispatch(cmd, groups[0], groups[1], groups[2]);
    if (d.timestamp_pool != VK_NULL_HANDLE) {
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, d.timestamp_pool, 1);
    }
    full_barrier(cmd);
}

/// Milliseconds between the two timestamps of the last dispatch, or a negative value if unavailable.
inline double read_timestamps_ms(const Device& d) {
    if (d.timestamp_pool == VK_NULL_HANDLE) return -1.0;
    std::array<std::uint64_t, 2> ticks{};
    const VkResult result = vkGetQueryPoolResults(d.device, d.timestamp_pool, 0, 2, sizeof ticks, ticks.data(),
                                                  sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT);
    if (result != VK_SUCCESS) return -1.0;
    const std::uint64_t mask =
        d.timestamp_valid_bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << d.timestamp_valid_bits) - 1;
    const std::uint64_t elapsed = (ticks[1] - ticks[0]) & mask;
    return static_cast<double>(elapsed) * static_cast<double>(d.properties.limits.timestampPeriod) * 1e-6;
}

}  // namespace detail

inline double Context::dispatch(Kernel& kernel, std::span<Buffer* const> buffers, const void* push,
                                std::size_t push_bytes, std::uint32_t groups_x, std::uint32_t groups_y,
                                std::uint32_t groups_z) {
    detail::Device& d = *device_;
    const std::array<std::uint32_t, 3> groups{groups_x, groups_y, groups_z};
    detail::check_dispatch(d, kernel, buffers, push, push_bytes, groups);
    std::lock_guard lock(d.submit_mutex);
    detail::bind_buffers(d, kernel, buffers);
    const auto start = std::chrono::steady_clock::now();
    d.submit_and_wait_locked(
        [&](VkCommandBuffer cmd) { detail::record_dispatch(d, cmd, kernel, push, push_bytes, groups); });
    const std::chrono::duration<double, std::milli> host_ms = std::chrono::steady_clock::now() - start;
    const double device_ms = detail::read_timestamps_ms(d);
    return device_ms >= 0.0 ? device_ms : host_ms.count();
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_RUNNER_HPP
