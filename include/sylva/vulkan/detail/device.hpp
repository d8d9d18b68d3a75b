// sylva/vulkan/detail/device.hpp -- the shared Vulkan device state behind Context, Buffer, Kernel.
//
// Not public API: Context owns a std::shared_ptr<Device>, and so does every Buffer and Kernel made
// from it, so the device outlives its resources whatever order they are destroyed in.
#ifndef SYLVA_VULKAN_DETAIL_DEVICE_HPP
#define SYLVA_VULKAN_DETAIL_DEVICE_HPP

#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>

#include "sylva/core/error.hpp"

namespace sylva::vk {

/// Optional device features that sylva enables when the device supports them.
struct DeviceFeatures {
    bool shader_int64 = false;          ///< 64-bit integers in shaders (GL_ARB_gpu_shader_int64).
    bool shader_int16 = false;          ///< 16-bit integers in shaders.
    bool storage_buffer_16bit = false;  ///< 16-bit loads and stores in storage buffers.
    bool storage_buffer_8bit = false;   ///< 8-bit loads and stores in storage buffers.
    bool timestamps = false;            ///< GPU timestamps on the compute queue.
};

namespace detail {

/// The name of a VkResult, for error messages.
inline std::string_view result_name(VkResult result) noexcept {
    switch (result) {
        case VK_SUCCESS:
            return "VK_SUCCESS";
        case VK_NOT_READY:
            return "VK_NOT_READY";
        case VK_TIMEOUT:
            return "VK_TIMEOUT";
        case VK_INCOMPLETE:
            return "VK_INCOMPLETE";
        case VK_ERROR_OUT_OF_HOST_MEMORY:
            return "VK_ERROR_OUT_OF_HOST_MEMORY";
        case VK_ERROR_OUT_OF_DEVICE_MEMORY:
            return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
        case VK_ERROR_INITIALIZATION_FAILED:
            return "VK_ERROR_INITIALIZATION_FAILED";
        case VK_ERROR_DEVICE_LOST:
            return "VK_ERROR_DEVICE_LOST";
        case VK_ERROR_MEMORY_MAP_FAILED:
            return "VK_ERROR_MEMORY_MAP_FAILED";
        case VK_ERROR_LAYER_NOT_PRESENT:
            return "VK_ERROR_LAYER_NOT_PRESENT";
        case VK_ERROR_EXTENSION_NOT_PRESENT:
            return "VK_ERROR_EXTENSION_NOT_PRESENT";
        case VK_ERROR_FEATURE_NOT_PRESENT:
            return "VK_ERROR_FEATURE_NOT_PRESENT";
        case VK_ERROR_INCOMPATIBLE_DRIVER:
            return "VK_ERROR_INCOMPATIBLE_DRIVER";
        case VK_ERROR_TOO_MANY_OBJECTS:
            return "VK_ERROR_TOO_MANY_OBJECTS";
        case VK_ERROR_OUT_OF_POOL_MEMORY:
            return "VK_ERROR_OUT_OF_POOL_MEMORY";
        case VK_ERROR_INVALID_SHADER_NV:
            return "VK_ERROR_INVALID_SHADER_NV";
        case VK_ERROR_UNKNOWN:
            return "VK_ERROR_UNKNOWN";
        default:
            return "VkResult(other)";
    }
}

/// A zero-initialised Vulkan struct with its sType set (aggregate init would leave -Wextra unhappy).
template <class T>
T make_struct(VkStructureType type) noexcept {
    T s{};
    s.sType = type;
    return s;
}

/// Throws sylva::Error("<what> failed: <result>") unless `result` is VK_SUCCESS.
inline void check(VkResult result, std::string_view what) {
    if (result != VK_SUCCESS) {
        throw Error(std::string(what) + " failed: " + std::string(result_name(result)) + " (" +
                    std::to_string(static_cast<int>(result)) + ")");
    }
}

/// "1.3.239" from a packed Vulkan version.
inline std::string version_string(std::uint32_t version) {
    return std::to_string(VK_API_VERSION_MAJOR(version)) + "." + std::to_string(VK_API_VERSION_MINOR(version)) + "." +
           std::to_string(VK_API_VERSION_PATCH(version));
}

/// Everything one logical device needs to run compute work synchronously: the handles, one
/// command buffer, one fence and a two-entry timestamp query pool. Created by Context; never copied.
struct Device {
    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    std::uint32_t queue_family = 0;
    VkCommandPool command_pool = VK_NULL_HANDLE;
    VkCommandBuffer command_buffer = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkQueryPool timestamp_pool = VK_NULL_HANDLE;
    std::uint32_t timestamp_valid_bits = 0;
    VkPhysicalDeviceProperties properties{};
    VkPhysicalDeviceMemoryProperties memory{};
    DeviceFeatures features{};
    VkDeviceSize max_allocation_bytes = 0;
    /// Whether the device cuts long loops: -1 not probed yet, 0 no, 1 yes (vk::loops_limited).
    std::atomic<int> loops_limited{-1};
    std::mutex submit_mutex;  ///< Guards the command buffer, the fence and descriptor updates.

    Device() = default;
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;

    ~Device() {
        if (device != VK_NULL_HANDLE) {
            vkDeviceWaitIdle(device);
            if (timestamp_pool != VK_NULL_HANDLE) vkDestroyQueryPool(device, timestamp_pool, nullptr);
            if (fence != VK_NULL_HANDLE) vkDestroyFence(device, fence, nullptr);
            if (command_pool != VK_NULL_HANDLE) vkDestroyCommandPool(device, command_pool, nullptr);
            vkDestroyDevice(device, nullptr);
        }
        if (instance != VK_NULL_HANDLE) vkDestroyInstance(instance, nullptr);
    }

    /// Records commands with `record(VkCommandBuffer)`, submits them and waits for completion.
    /// The caller holds `submit_mutex`.
    template <class Record>
    void submit_and_wait_locked(Record&& record) {
        check(vkResetCommandBuffer(command_buffer, 0), "vkResetCommandBuffer");
        auto begin = make_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        check(vkBeginCommandBuffer(command_buffer, &begin), "vkBeginCommandBuffer");
        record(command_buffer);
        check(vkEndCommandBuffer(command_buffer), "vkEndCommandBuffer");
        auto submit = make_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &command_buffer;
        check(vkQueueSubmit(queue, 1, &submit, fence), "vkQueueSubmit");
        const VkResult waited = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
        check(vkResetFences(device, 1, &fence), "vkResetFences");
        check(waited, "vkWaitForFences (the dispatch did not complete)");
    }

    /// Locks, then records, submits and waits (see submit_and_wait_locked).
    template <class Record>
    void submit_and_wait(Record&& record) {
        std::lock_guard lock(submit_mutex);
        submit_and_wait_locked(static_cast<Record&&>(record));
    }

    /// The index of a memory type allowed by `type_bits` that has all `required` flags,
    /// preferring one that also has all `preferred` flags; -1 when there is none.
    [[nodiscard]] int find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                       VkMemoryPropertyFlags preferred) const noexcept {
        int fallback = -1;
        for (std::uint32_t i = 0; i < memory.memoryTypeCount; ++i) {
            const VkMemoryPropertyFlags flags = memory.memoryTypes[i].propertyFlags;
            if ((type_bits & (1u << i)) == 0 || (flags & required) != required) continue;
            if ((flags & preferred) == preferred) return static_cast<int>(i);
            if (fallback < 0) fallback = static_cast<int>(i);
        }
        return fallback;
    }
};

/// A full memory barrier between whatever came before and whatever comes after on the queue:
/// transfer and compute writes become visible to compute, transfer and host reads.
inline void full_barrier(VkCommandBuffer command_buffer) {
    auto barrier = make_struct<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
    barrier.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    vkCmdPipelineBarrier(command_buffer, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0, nullptr, 0,
                         nullptr);
}

}  // namespace detail
}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_DETAIL_DEVICE_HPP
