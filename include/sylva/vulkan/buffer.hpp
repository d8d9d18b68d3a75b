// sylva/vulkan/buffer.hpp -- a storage buffer with upload and download.
#ifndef SYLVA_VULKAN_BUFFER_HPP
#define SYLVA_VULKAN_BUFFER_HPP

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <ranges>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/context.hpp"
#include "sylva/vulkan/detail/device.hpp"

namespace sylva::vk {
namespace detail {

/// A VkBuffer with its own memory, mapped when host-visible. Plain handles; Buffer owns them.
struct Allocation {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    void* mapped = nullptr;  ///< Host pointer for host-visible coherent memory, else nullptr.

    /// Frees the handles (safe on an empty allocation).
    void release(VkDevice device) noexcept {
        if (mapped != nullptr) vkUnmapMemory(device, memory);
        if (buffer != VK_NULL_HANDLE) vkDestroyBuffer(device, buffer, nullptr);
        if (memory != VK_NULL_HANDLE) vkFreeMemory(device, memory, nullptr);
        *this = Allocation{};
    }
};

/// Creates a buffer of `bytes` in memory with `required` flags (preferring `preferred` as well),
/// mapping it when `map` is set and the memory is host-visible and coherent. Returns an empty
/// allocation when no memory type has the required flags; throws sylva::Error when allocation fails.
inline Allocation allocate(const Device& d, VkDeviceSize bytes, VkBufferUsageFlags usage,
                           VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred, bool map) {
    Allocation a;
    auto info = make_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    info.size = bytes;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    check(vkCreateBuffer(d.device, &info, nullptr, &a.buffer), "vkCreateBuffer of " + std::to_string(bytes) + " bytes");
    try {
        VkMemoryRequirements needs{};
        vkGetBufferMemoryRequirements(d.device, a.buffer, &needs);
        const int type = d.find_memory_type(needs.memoryTypeBits, required, preferred);
        if (type < 0) {
            a.release(d.device);
            return a;
        }
        auto allocate_info = make_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
        allocate_info.allocationSize = needs.size;
        allocate_info.memoryTypeIndex = static_cast<std::uint32_t>(type);
        check(vkAllocateMemory(d.device, &allocate_info, nullptr, &a.memory),
              "vkAllocateMemory of " + std::to_string(needs.size) + " bytes");
        check(vkBindBufferMemory(d.device, a.buffer, a.memory, 0), "vkBindBufferMemory");
        const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        if (map && (d.memory.memoryTypes[type].propertyFlags & host) == host) {
            check(vkMapMemory(d.device, a.memory, 0, VK_WHOLE_SIZE, 0, &a.mapped), "vkMapMemory");
        }
    } catch (...) {
        a.release(d.device);
        throw;
    }
    return a;
}

/// A host-visible, coherent, mapped transfer buffer of `bytes`, released when it goes out of scope.
struct Staging {
    const Device& device;
    Allocation allocation;

    Staging(const Device& d, VkDeviceSize bytes)
        : device(d),
          allocation(allocate(d, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                              VK_MEMORY_PROPERTY_HOST_CACHED_BIT, true)) {
        if (allocation.mapped == nullptr) throw Error("no host-visible coherent memory for a staging buffer");
    }
    Staging(const Staging&) = delete;
    Staging& operator=(const Staging&) = delete;
    ~Staging() { allocation.release(device.device); }
};

/// Copies `bytes` from `source` at `source_offset` to `target` at `target_offset` on the queue.
inline void copy_on_device(Device& d, VkBuffer source, VkDeviceSize source_offset, VkBuffer target,
                           VkDeviceSize target_offset, VkDeviceSize bytes) {
    d.submit_and_wait([&](VkCommandBuffer cmd) {
        full_barrier(cmd);
        const VkBufferCopy region{source_offset, target_offset, bytes};
        vkCmdCopyBuffer(cmd, source, target, 1, &region);
        full_barrier(cmd);
    });
}

}  // namespace detail

/// Where a Buffer's memory lives and how the host reaches it.
enum class BufferMemory {
    automatic,  ///< Device-local with staging copies on discrete GPUs; host-visible, mapped, elsewhere.
    staged,     ///< Device-local when available, never mapped: every transfer goes through staging.
};

/// A storage buffer on the device, zero-filled on creation. On discrete GPUs it lives in
/// device-local memory and transfers go through a staging buffer; elsewhere (integrated GPUs,
/// lavapipe) it is host-visible coherent memory written and read directly (see BufferMemory).
/// Movable, not copyable; keeps its device alive.
class Buffer {
public:
    /// A buffer of `bytes` bytes. Zero bytes allocate a 4-byte dummy so the buffer can be bound.
    Buffer(Context& context, std::size_t bytes, BufferMemory memory = BufferMemory::automatic)
        : device_(context.shared_device()), bytes_(bytes) {
        const VkDeviceSize allocated = bytes == 0 ? 4 : (static_cast<VkDeviceSize>(bytes) + 3) / 4 * 4;
        check_allocation_size(allocated);
        const VkBufferUsageFlags usage =
            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        const VkMemoryPropertyFlags local = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
        const bool staged =
            memory == BufferMemory::staged || context.device_type() == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
        if (staged) allocation_ = detail::allocate(*device_, allocated, usage, local, 0, false);
        if (allocation_.buffer == VK_NULL_HANDLE && !staged) {
            allocation_ = detail::allocate(*device_, allocated, usage, host, VK_MEMORY_PROPERTY_HOST_CACHED_BIT, true);
        }
        if (allocation_.buffer == VK_NULL_HANDLE) {
            allocation_ = detail::allocate(*device_, allocated, usage, 0, local, !staged);
        }
        if (allocation_.buffer == VK_NULL_HANDLE) throw Error("no Vulkan memory type can hold a storage buffer");
        allocated_ = allocated;
        try {
            fill(0u);
        } catch (...) {
            release();
            throw;
        }
    }

    Buffer(Buffer&& other) noexcept
        : device_(std::move(other.device_)),
          allocation_(std::exchange(other.allocation_, {})),
          bytes_(std::exchange(other.bytes_, 0)),
          allocated_(std::exchange(other.allocated_, 0)) {}
    Buffer& operator=(Buffer&& other) noexcept {
        if (this != &other) {
            release();
            device_ = std::move(other.device_);
            allocation_ = std::exchange(other.allocation_, {});
            bytes_ = std::exchange(other.bytes_, 0);
            allocated_ = std::exchange(other.allocated_, 0);
        }
        return *this;
    }
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;
    ~Buffer() { release(); }

    /// The size asked for, in bytes (0 for a dummy).
    [[nodiscard]] std::size_t size_bytes() const noexcept { return bytes_; }
    /// The size actually allocated and bound, in bytes (at least 4, a multiple of 4).
    [[nodiscard]] std::size_t bound_bytes() const noexcept { return static_cast<std::size_t>(allocated_); }
    /// Whether the host reads and writes the memory directly (no staging copies).
    [[nodiscard]] bool host_visible() const noexcept { return allocation_.mapped != nullptr; }
    /// The raw buffer handle.
    [[nodiscard]] VkBuffer handle() const noexcept { return allocation_.buffer; }
    /// The shared device state this buffer belongs to.
    [[nodiscard]] const detail::Device* device() const noexcept { return device_.get(); }

    /// Copies `bytes` into the buffer starting at byte `offset`; throws if it does not fit.
    void upload_bytes(std::span<const std::byte> bytes, std::size_t offset = 0) {
        check_range(offset, bytes.size(), "upload");
        if (bytes.empty()) return;
        if (host_visible()) {
            std::memcpy(static_cast<std::byte*>(allocation_.mapped) + offset, bytes.data(), bytes.size());
            return;
        }
        detail::Staging staging(*device_, bytes.size());
        std::memcpy(staging.allocation.mapped, bytes.data(), bytes.size());
        detail::copy_on_device(*device_, staging.allocation.buffer, 0, allocation_.buffer, offset, bytes.size());
    }

    /// Copies bytes from the buffer starting at byte `offset` into `bytes`; throws if out of range.
    void download_bytes(std::span<std::byte> bytes, std::size_t offset = 0) const {
        check_range(offset, bytes.size(), "download");
        if (bytes.empty()) return;
        if (host_visible()) {
            std::memcpy(bytes.data(), static_cast<const std::byte*>(allocation_.mapped) + offset, bytes.size());
            return;
        }
        detail::Staging staging(*device_, bytes.size());
        detail::copy_on_device(*device_, allocation_.buffer, offset, staging.allocation.buffer, 0, bytes.size());
        std::memcpy(bytes.data(), staging.allocation.mapped, bytes.size());
    }

    /// Copies 32-bit words into the buffer starting at word `first_word`.
    void upload(std::span<const std::uint32_t> words, std::size_t first_word = 0) {
        upload_bytes(std::as_bytes(words), first_word * sizeof(std::uint32_t));
    }

    /// Copies 32-bit words out of the buffer starting at word `first_word`.
    void download(std::span<std::uint32_t> words, std::size_t first_word = 0) const {
        download_bytes(std::as_writable_bytes(words), first_word * sizeof(std::uint32_t));
    }

    /// All whole words of the requested size, downloaded.
    [[nodiscard]] std::vector<std::uint32_t> download_words() const {
        std::vector<std::uint32_t> words(bytes_ / sizeof(std::uint32_t));
        download(words);
        return words;
    }

    /// Sets every word of the bound range to `value`.
    void fill(std::uint32_t value) {
        if (host_visible()) {
            auto* words = static_cast<std::uint32_t*>(allocation_.mapped);
            std::fill(words, words + allocated_ / sizeof(std::uint32_t), value);
            return;
        }
        device_->submit_and_wait([&](VkCommandBuffer cmd) {
            detail::full_barrier(cmd);
            vkCmdFillBuffer(cmd, allocation_.buffer, 0, VK_WHOLE_SIZE, value);
            detail::full_barrier(cmd);
        });
    }

private:
    void check_allocation_size(VkDeviceSize bytes) const {
        if (device_->max_allocation_bytes != 0 && bytes > device_->max_allocation_bytes) {
            throw Error("a Vulkan buffer of " + std::to_string(bytes) + " bytes exceeds this device's " +
                        "maxMemoryAllocationSize of " + std::to_string(device_->max_allocation_bytes) + " bytes");
        }
    }

    void check_range(std::size_t offset, std::size_t count, const char* what) const {
        if (offset > allocated_ || count > allocated_ - offset) {
            throw Error(std::string("Buffer::") + what + " of " + std::to_string(count) + " bytes at offset " +
                        std::to_string(offset) + " overruns a buffer of " + std::to_string(allocated_) + " bytes");
        }
    }

    void release() noexcept {
        if (device_) allocation_.release(device_->device);
        device_.reset();
    }

    std::shared_ptr<detail::Device> device_;
    detail::Allocation allocation_;
    std::size_t bytes_ = 0;
    VkDeviceSize allocated_ = 0;
};

/// A storage buffer holding `records` byte for byte: a user's element buffer (any contiguous
/// range of a trivially copyable record type: a vector, an array, a span of float/uint words in
/// the layout the user's shader reads with std430), a ray buffer, a table. An empty range gives
/// a bindable 4-byte dummy.
template <std::ranges::contiguous_range R>
    requires std::ranges::sized_range<R> && std::is_trivially_copyable_v<std::ranges::range_value_t<R>>
Buffer upload_buffer(Context& context, const R& records, BufferMemory memory = BufferMemory::automatic) {
    const std::span<const std::ranges::range_value_t<R>> view(std::ranges::data(records), std::ranges::size(records));
    Buffer buffer(context, view.size_bytes(), memory);
    buffer.upload_bytes(std::as_bytes(view));
    return buffer;
}

/// Downloads a whole buffer as records of T (size_bytes() / sizeof(T) of them).
template <class T>
    requires std::is_trivially_copyable_v<T>
std::vector<T> download_records(const Buffer& buffer) {
    std::vector<T> records(buffer.size_bytes() / sizeof(T));
    buffer.download_bytes(std::as_writable_bytes(std::span<T>(records)));
    return records;
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_BUFFER_HPP
