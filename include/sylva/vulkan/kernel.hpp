// sylva/vulkan/kernel.hpp -- a compute pipeline: SPIR-V, storage buffer bindings, push constants
// and specialization constants.
#ifndef SYLVA_VULKAN_KERNEL_HPP
#define SYLVA_VULKAN_KERNEL_HPP

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/context.hpp"
#include "sylva/vulkan/detail/device.hpp"
#include "sylva/vulkan/detail/spirv_check.hpp"

namespace sylva::vk {
namespace detail {

/// The Vulkan objects of one kernel. Plain handles; Kernel owns them.
struct PipelineObjects {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;  ///< Freed with the pool.

    /// Destroys whatever was created (safe on a partial or empty set of objects).
    void release(VkDevice device) noexcept {
        if (pipeline != VK_NULL_HANDLE) vkDestroyPipeline(device, pipeline, nullptr);
        if (layout != VK_NULL_HANDLE) vkDestroyPipelineLayout(device, layout, nullptr);
        if (pool != VK_NULL_HANDLE) vkDestroyDescriptorPool(device, pool, nullptr);
        if (set_layout != VK_NULL_HANDLE) vkDestroyDescriptorSetLayout(device, set_layout, nullptr);
        if (module != VK_NULL_HANDLE) vkDestroyShaderModule(device, module, nullptr);
        *this = PipelineObjects{};
    }
};

/// Creates the shader module from checked SPIR-V.
inline void create_module(const Device& d, std::span<const std::uint32_t> spirv, PipelineObjects& p) {
    auto info = make_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    info.codeSize = spirv.size_bytes();
    info.pCode = spirv.data();
    check(vkCreateShaderModule(d.device, &info, nullptr, &p.module), "vkCreateShaderModule");
}

/// Creates the set-0 layout (binding i = storage buffer i), its pool and set, and the pipeline layout.
inline void create_layouts(const Device& d, std::uint32_t buffer_count, std::uint32_t push_bytes, PipelineObjects& p) {
    std::vector<VkDescriptorSetLayoutBinding> bindings(buffer_count);
    for (std::uint32_t i = 0; i < buffer_count; ++i) {
        bindings[i] =
            VkDescriptorSetLayoutBinding{i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    }
    auto set_info = make_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    set_info.bindingCount = buffer_count;
    set_info.pBindings = bindings.data();
    check(vkCreateDescriptorSetLayout(d.device, &set_info, nullptr, &p.set_layout), "vkCreateDescriptorSetLayout");
    const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
    auto layout_info = make_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = &p.set_layout;
    layout_info.pushConstantRangeCount = push_bytes > 0 ? 1u : 0u;
    layout_info.pPushConstantRanges = &push;
    check(vkCreatePipelineLayout(d.device, &layout_info, nullptr, &p.layout), "vkCreatePipelineLayout");
    if (buffer_count == 0) return;
    const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, buffer_count};
    auto pool_info = make_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pool_info.maxSets = 1;
    pool_info.poolSizeCount = 1;
    pool_info.pPoolSizes = &size;
    check(vkCreateDescriptorPool(d.device, &pool_info, nullptr, &p.pool), "vkCreateDescriptorPool");
    auto allocate = make_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    allocate.descriptorPool = p.pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &p.set_layout;
    check(vkAllocateDescriptorSets(d.device, &allocate, &p.set), "vkAllocateDescriptorSets");
}

/// Creates the compute pipeline, with constant_id i = specialization[i].
inline void create_pipeline(const Device& d, std::span<const std::uint32_t> specialization, PipelineObjects& p) {
    std::vector<VkSpecializationMapEntry> entries(specialization.size());
    for (std::size_t i = 0; i < specialization.size(); ++i) {
        entries[i] =
            VkSpecializationMapEntry{static_cast<std::uint32_t>(i),
                                     static_cast<std::uint32_t>(i * sizeof(std::uint32_t)), sizeof(std::uint32_t)};
    }
    VkSpecializationInfo constants{};
    constants.mapEntryCount = static_cast<std::uint32_t>(entries.size());
    constants.pMapEntries = entries.data();
    constants.dataSize = specialization.size_bytes();
    constants.pData = specialization.data();
    auto info = make_struct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    info.stage = make_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = p.module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = specialization.empty() ? nullptr : &constants;
    info.layout = p.layout;
    check(vkCreateComputePipelines(d.device, VK_NULL_HANDLE, 1, &info, nullptr, &p.pipeline),
          "vkCreateComputePipelines");
}

}  // namespace detail

/// A compute kernel: SPIR-V whose resources are `storage_buffer_count` storage buffers at
/// descriptor set 0, bindings 0..n-1, plus `push_constant_bytes` of push constants, with
/// specialization constants constant_id 0..n-1 (one uint32 each). Run it with Context::dispatch.
/// Movable, not copyable; keeps its device alive.
class Kernel {
public:
    /// Checks the SPIR-V on the host (header, instruction lengths, compute entry point "main",
    /// bindings within set 0 and below `storage_buffer_count`) and builds the pipeline.
    /// Throws sylva::Error naming the problem.
    Kernel(Context& context, std::span<const std::uint32_t> spirv, std::uint32_t storage_buffer_count,
           std::uint32_t push_constant_bytes, std::span<const std::uint32_t> specialization_constants = {})
        : device_(context.shared_device()), buffer_count_(storage_buffer_count), push_bytes_(push_constant_bytes) {
        check_limits(context);
        detail::check_spirv(spirv, storage_buffer_count, context.api_version());
        try {
            detail::create_module(*device_, spirv, objects_);
            detail::create_layouts(*device_, storage_buffer_count, push_constant_bytes, objects_);
            detail::create_pipeline(*device_, specialization_constants, objects_);
        } catch (...) {
            objects_.release(device_->device);
            throw;
        }
    }

    Kernel(Kernel&& other) noexcept
        : device_(std::move(other.device_)),
          objects_(std::exchange(other.objects_, {})),
          buffer_count_(other.buffer_count_),
          push_bytes_(other.push_bytes_) {}
    Kernel& operator=(Kernel&& other) noexcept {
        if (this != &other) {
            release();
            device_ = std::move(other.device_);
            objects_ = std::exchange(other.objects_, {});
            buffer_count_ = other.buffer_count_;
            push_bytes_ = other.push_bytes_;
        }
        return *this;
    }
    Kernel(const Kernel&) = delete;
    Kernel& operator=(const Kernel&) = delete;
    ~Kernel() { release(); }

    /// How many storage buffers a dispatch binds.
    [[nodiscard]] std::uint32_t storage_buffer_count() const noexcept { return buffer_count_; }
    /// How many bytes of push constants a dispatch supplies.
    [[nodiscard]] std::uint32_t push_constant_bytes() const noexcept { return push_bytes_; }
    [[nodiscard]] VkPipeline pipeline() const noexcept { return objects_.pipeline; }             ///< Raw handle.
    [[nodiscard]] VkPipelineLayout pipeline_layout() const noexcept { return objects_.layout; }  ///< Raw handle.
    [[nodiscard]] VkDescriptorSet descriptor_set() const noexcept { return objects_.set; }       ///< Raw handle.
    /// The shared device state this kernel belongs to.
    [[nodiscard]] const detail::Device* device() const noexcept { return device_.get(); }

private:
    void check_limits(const Context& context) const {
        const VkPhysicalDeviceLimits& limits = context.properties().limits;
        if (push_bytes_ % 4 != 0 || push_bytes_ > limits.maxPushConstantsSize) {
            throw Error("Kernel push constants of " + std::to_string(push_bytes_) + " bytes: must be a multiple " +
                        "of 4 and at most " + std::to_string(limits.maxPushConstantsSize));
        }
        if (buffer_count_ > limits.maxPerStageDescriptorStorageBuffers) {
            throw Error("Kernel with " + std::to_string(buffer_count_) + " storage buffers exceeds the device " +
                        "limit of " + std::to_string(limits.maxPerStageDescriptorStorageBuffers));
        }
    }

    void release() noexcept {
        if (device_) objects_.release(device_->device);
        device_.reset();
    }

    std::shared_ptr<detail::Device> device_;
    detail::PipelineObjects objects_;
    std::uint32_t buffer_count_ = 0;
    std::uint32_t push_bytes_ = 0;
};

/// The traversal stack a kernel is specialised for, for a tree `depth` levels deep whose
/// structure caps depths at `cap`: the next power of two at or above the depth, at least 8,
/// at most the cap. Trees of similar depth then share one pipeline: a tree rebuilt after a
/// transfer-function edit or a frame of moving elements rarely leaves its bucket, and each
/// new stack size would be a new pipeline (lavapipe compiles one in 5-250 s; see
/// docs/DESIGN.md, "Pipelines"). The stack is at most twice what the tree needs.
[[nodiscard]] inline std::uint32_t stack_entries_for(std::uint32_t depth, std::uint32_t cap) {
    std::uint32_t entries = 8;
    while (entries < depth && entries < cap) entries <<= 1;
    return std::max(std::min(entries, cap), depth);
}

/// Reads a SPIR-V module from a .spv file (for shaders compiled outside the build; embedded
/// arrays from sylva_add_spirv need no file). Throws sylva::Error naming the file when it cannot
/// be read or is not a whole number of 32-bit words; Kernel checks the words themselves.
inline std::vector<std::uint32_t> read_spirv_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw Error("read_spirv_file: cannot open '" + path + "'");
    const std::streamoff bytes = in.tellg();
    if (bytes <= 0 || bytes % 4 != 0)
        throw Error("read_spirv_file: '" + path + "' has " + std::to_string(bytes) +
                    " bytes, not a positive whole number of 32-bit words");
    std::vector<std::uint32_t> words(static_cast<std::size_t>(bytes / 4));
    in.seekg(0);
    if (!in.read(reinterpret_cast<char*>(words.data()), bytes)) throw Error("read_spirv_file: cannot read '" + path + "'");
    return words;
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_KERNEL_HPP
