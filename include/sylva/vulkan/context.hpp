// sylva/vulkan/context.hpp -- a Vulkan instance, one physical device picked by policy, a logical
// device with one compute queue. Include <sylva/vulkan/runner.hpp> to get dispatch as well.
#ifndef SYLVA_VULKAN_CONTEXT_HPP
#define SYLVA_VULKAN_CONTEXT_HPP

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/detail/device.hpp"

namespace sylva::vk {

class Buffer;
class Kernel;

/// The environment variable that overrides which device Context::create() picks.
inline constexpr const char* device_environment_variable = "SYLVA_VULKAN_DEVICE";

namespace detail {

/// One physical device as seen during selection.
struct Candidate {
    VkPhysicalDevice handle = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties{};
    std::uint32_t index = 0;           ///< Position in vkEnumeratePhysicalDevices order.
    int compute_family = -1;           ///< A queue family with compute, -1 if none.
    std::uint32_t timestamp_bits = 0;  ///< timestampValidBits of that family.
};

/// "cpu", "discrete-gpu", ... for messages.
inline std::string_view device_type_name(VkPhysicalDeviceType type) noexcept {
    switch (type) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return "discrete-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return "integrated-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return "virtual-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return "cpu";
        default:
            return "other";
    }
}

/// Preference under "auto": discrete GPU, integrated, virtual, CPU, anything else.
inline int device_type_rank(VkPhysicalDeviceType type) noexcept {
    switch (type) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return 0;
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return 1;
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return 2;
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return 3;
        default:
            return 4;
    }
}

inline std::string lower_case(std::string_view text) {
    std::string out(text);
    std::transform(out.begin(), out.end(), out.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

/// Whether sylva can run on the candidate: Vulkan 1.1 and a compute queue.
inline bool usable(const Candidate& c) noexcept {
    return c.compute_family >= 0 && c.properties.apiVersion >= VK_API_VERSION_1_1;
}

/// "0: llvmpipe (LLVM 15.0.6, 256 bits) [cpu, Vulkan 1.3.230]" for each device, one per line.
inline std::string describe_candidates(const std::vector<Candidate>& candidates) {
    std::string text;
    for (const Candidate& c : candidates) {
        text += "\n  " + std::to_string(c.index) + ": " + c.properties.deviceName + " [" +
                std::string(device_type_name(c.properties.deviceType)) + ", Vulkan " +
                version_string(c.properties.apiVersion) + (usable(c) ? "" : ", unusable: needs Vulkan 1.1 + compute") +
                "]";
    }
    return text;
}

/// Picks the compute queue family, preferring one with timestamps.
inline void find_compute_family(Candidate& c) {
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c.handle, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(c.handle, &count, families.data());
    for (std::uint32_t i = 0; i < count; ++i) {
        if ((families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) == 0) continue;
        if (c.compute_family < 0 || (c.timestamp_bits == 0 && families[i].timestampValidBits > 0)) {
            c.compute_family = static_cast<int>(i);
            c.timestamp_bits = families[i].timestampValidBits;
        }
    }
}

/// All physical devices of the instance, in enumeration order.
inline std::vector<Candidate> enumerate_candidates(VkInstance instance) {
    std::uint32_t count = 0;
    check(vkEnumeratePhysicalDevices(instance, &count, nullptr), "no Vulkan device: vkEnumeratePhysicalDevices");
    std::vector<VkPhysicalDevice> handles(count);
    const VkResult listed = vkEnumeratePhysicalDevices(instance, &count, handles.data());
    if (listed != VK_INCOMPLETE) check(listed, "no Vulkan device: vkEnumeratePhysicalDevices");
    std::vector<Candidate> candidates;
    for (std::uint32_t i = 0; i < count; ++i) {
        Candidate c;
        c.handle = handles[i];
        c.index = i;
        vkGetPhysicalDeviceProperties(c.handle, &c.properties);
        find_compute_family(c);
        candidates.push_back(c);
    }
    return candidates;
}

/// The best usable candidate under "auto" among those `accept` admits, or nullptr.
template <class Accept>
const Candidate* best_candidate(const std::vector<Candidate>& candidates, Accept accept) {
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates) {
        if (!usable(c) || !accept(c)) continue;
        if (best == nullptr ||
            device_type_rank(c.properties.deviceType) < device_type_rank(best->properties.deviceType))
            best = &c;
    }
    return best;
}

/// Whether a request is a device index: decimal digits only.
inline bool is_index_request(std::string_view request) noexcept {
    return !request.empty() && request.size() <= 9 &&
           std::all_of(request.begin(), request.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; });
}

/// The usable candidate at a decimal index in enumeration order, or nullptr.
inline const Candidate* candidate_by_index(const std::vector<Candidate>& candidates, std::string_view request) {
    const std::size_t index = std::stoul(std::string(request));
    return index < candidates.size() && usable(candidates[index]) ? &candidates[index] : nullptr;
}

/// Applies a SYLVA_VULKAN_DEVICE request ("auto", "cpu", "gpu", an index or a name substring).
inline const Candidate* select_candidate(const std::vector<Candidate>& candidates, std::string_view request) {
    const std::string wanted = lower_case(request);
    if (wanted.empty() || wanted == "auto") return best_candidate(candidates, [](const Candidate&) { return true; });
    if (wanted == "cpu")
        return best_candidate(
            candidates, [](const Candidate& c) { return c.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; });
    if (wanted == "gpu")
        return best_candidate(
            candidates, [](const Candidate& c) { return c.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU; });
    if (is_index_request(wanted)) return candidate_by_index(candidates, wanted);
    return best_candidate(candidates, [&](const Candidate& c) {
        return lower_case(c.properties.deviceName).find(wanted) != std::string::npos;
    });
}

/// A Vulkan 1.1+ instance; throws "no Vulkan device: ..." when there is no loader or driver.
inline VkInstance create_instance() {
    std::uint32_t loader_version = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS || loader_version < VK_API_VERSION_1_1) {
        throw Error("no Vulkan device: the Vulkan loader supports only Vulkan " + version_string(loader_version) +
                    "; sylva needs 1.1 (install libvulkan1 >= 1.1)");
    }
    auto app = make_struct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.pApplicationName = "sylva";
    app.pEngineName = "sylva";
    app.apiVersion = std::min<std::uint32_t>(loader_version, VK_API_VERSION_1_3);
    auto info = make_struct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    info.pApplicationInfo = &app;
    VkInstance instance = VK_NULL_HANDLE;
    const VkResult result = vkCreateInstance(&info, nullptr, &instance);
    if (result != VK_SUCCESS) {
        throw Error("no Vulkan device: vkCreateInstance failed with " + std::string(result_name(result)) +
                    " (no Vulkan driver installed? on Debian: apt install mesa-vulkan-drivers for lavapipe)");
    }
    return instance;
}

/// The optional features of `physical` that sylva enables, as Vulkan feature structs.
struct FeatureChain {
    VkPhysicalDeviceFeatures2 core =
        make_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    VkPhysicalDevice16BitStorageFeatures storage16 =
        make_struct<VkPhysicalDevice16BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
    VkPhysicalDevice8BitStorageFeatures storage8 =
        make_struct<VkPhysicalDevice8BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_8BIT_STORAGE_FEATURES);

    /// Queries support; 8-bit storage only on Vulkan 1.2 devices, where it is core.
    FeatureChain(VkPhysicalDevice physical, std::uint32_t api_version) {
        core.pNext = &storage16;
        if (api_version >= VK_API_VERSION_1_2) storage16.pNext = &storage8;
        vkGetPhysicalDeviceFeatures2(physical, &core);
    }
    FeatureChain(const FeatureChain&) = delete;
    FeatureChain& operator=(const FeatureChain&) = delete;

    /// Keeps only the features sylva asks for (each only if supported) and reports them.
    DeviceFeatures keep_wanted() {
        DeviceFeatures enabled;
        enabled.shader_int64 = core.features.shaderInt64 == VK_TRUE;
        enabled.shader_int16 = core.features.shaderInt16 == VK_TRUE;
        enabled.storage_buffer_16bit = storage16.storageBuffer16BitAccess == VK_TRUE;
        enabled.storage_buffer_8bit = storage16.pNext != nullptr && storage8.storageBuffer8BitAccess == VK_TRUE;
        core.features = VkPhysicalDeviceFeatures{};
        core.features.shaderInt64 = enabled.shader_int64 ? VK_TRUE : VK_FALSE;
        core.features.shaderInt16 = enabled.shader_int16 ? VK_TRUE : VK_FALSE;
        const VkPhysicalDevice16BitStorageFeatures storage16_query = storage16;
        storage16 =
            make_struct<VkPhysicalDevice16BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_16BIT_STORAGE_FEATURES);
        storage16.pNext = storage16_query.pNext;
        storage16.storageBuffer16BitAccess = enabled.storage_buffer_16bit ? VK_TRUE : VK_FALSE;
        storage8 =
            make_struct<VkPhysicalDevice8BitStorageFeatures>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_8BIT_STORAGE_FEATURES);
        storage8.storageBuffer8BitAccess = enabled.storage_buffer_8bit ? VK_TRUE : VK_FALSE;
        return enabled;
    }
};

/// Creates the logical device with one compute queue and the supported optional features.
inline void create_logical_device(Device& d, const Candidate& chosen) {
    d.physical = chosen.handle;
    d.properties = chosen.properties;
    d.queue_family = static_cast<std::uint32_t>(chosen.compute_family);
    d.timestamp_valid_bits = chosen.timestamp_bits;
    vkGetPhysicalDeviceMemoryProperties(d.physical, &d.memory);
    auto maintenance3 =
        make_struct<VkPhysicalDeviceMaintenance3Properties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES);
    auto properties2 = make_struct<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
    properties2.pNext = &maintenance3;
    vkGetPhysicalDeviceProperties2(d.physical, &properties2);
    d.max_allocation_bytes = maintenance3.maxMemoryAllocationSize;

    FeatureChain chain(d.physical, d.properties.apiVersion);
    d.features = chain.keep_wanted();
    d.features.timestamps = d.timestamp_valid_bits > 0 && d.properties.limits.timestampPeriod > 0.0f;
    const float priority = 1.0f;
    auto queue = make_struct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    queue.queueFamilyIndex = d.queue_family;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    auto info = make_struct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    info.pNext = &chain.core;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queue;
    check(vkCreateDevice(d.physical, &info, nullptr, &d.device),
          std::string("vkCreateDevice on ") + d.properties.deviceName);
    vkGetDeviceQueue(d.device, d.queue_family, 0, &d.queue);
}

/// Creates the command pool and buffer, the fence and (when supported) the timestamp queries.
inline void create_submission_objects(Device& d) {
    auto pool = make_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool.queueFamilyIndex = d.queue_family;
    check(vkCreateCommandPool(d.device, &pool, nullptr, &d.command_pool), "vkCreateCommandPool");
    auto allocate = make_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    allocate.commandPool = d.command_pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(d.device, &allocate, &d.command_buffer), "vkAllocateCommandBuffers");
    auto fence = make_struct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
    check(vkCreateFence(d.device, &fence, nullptr, &d.fence), "vkCreateFence");
    if (d.features.timestamps) {
        auto queries = make_struct<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
        queries.queryType = VK_QUERY_TYPE_TIMESTAMP;
        queries.queryCount = 2;
        check(vkCreateQueryPool(d.device, &queries, nullptr, &d.timestamp_pool), "vkCreateQueryPool");
    }
}

/// The device a request names, or a sylva::Error that names the request and lists the devices.
inline const Candidate& require_candidate(const std::vector<Candidate>& candidates, std::string_view request) {
    if (candidates.empty()) throw Error("no Vulkan device: the Vulkan loader found no physical device");
    if (const Candidate* chosen = select_candidate(candidates, request)) return *chosen;
    throw Error(
        "no Vulkan device matches " + std::string(device_environment_variable) + "='" + std::string(request) +
        "' (use auto, cpu, gpu, an index or part of a device name); devices:" + describe_candidates(candidates));
}

}  // namespace detail

/// A Vulkan device ready for compute: instance, chosen physical device, logical device, one
/// compute queue. Movable, not copyable. Buffers and kernels made from a Context keep its device
/// alive, so they may outlive the Context object. Dispatches from several threads are serialised.
class Context {
public:
    /// Picks the device named by the environment variable SYLVA_VULKAN_DEVICE: `auto` (default:
    /// discrete GPU, then integrated, virtual, then CPU such as lavapipe), `cpu`, `gpu`, a decimal
    /// index in enumeration order, or a case-insensitive part of the device name.
    /// Throws sylva::Error("no Vulkan device: ...") when Vulkan or a matching device is missing.
    static Context create() {
        const char* request = std::getenv(device_environment_variable);
        return create(request != nullptr ? std::string_view(request) : std::string_view("auto"));
    }

    /// Picks the device named by `request`, with the same rules as the environment variable.
    static Context create(std::string_view request) {
        auto device = std::make_shared<detail::Device>();
        device->instance = detail::create_instance();
        const std::vector<detail::Candidate> candidates = detail::enumerate_candidates(device->instance);
        detail::create_logical_device(*device, detail::require_candidate(candidates, request));
        detail::create_submission_objects(*device);
        return Context(std::move(device));
    }

    Context(Context&&) noexcept = default;
    Context& operator=(Context&&) noexcept = default;
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    ~Context() = default;

    /// The device name reported by the driver, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    [[nodiscard]] std::string device_name() const { return device_->properties.deviceName; }
    /// The device type (discrete, integrated, virtual, CPU).
    [[nodiscard]] VkPhysicalDeviceType device_type() const noexcept { return device_->properties.deviceType; }
    /// Whether the device is a CPU implementation such as lavapipe.
    [[nodiscard]] bool is_cpu() const noexcept { return device_type() == VK_PHYSICAL_DEVICE_TYPE_CPU; }
    /// The largest range of one storage buffer binding, in bytes (128 MiB on lavapipe).
    [[nodiscard]] std::size_t max_storage_buffer_range() const noexcept {
        return device_->properties.limits.maxStorageBufferRange;
    }
    /// The device's Vulkan version, packed as by VK_MAKE_API_VERSION.
    [[nodiscard]] std::uint32_t api_version() const noexcept { return device_->properties.apiVersion; }
    /// The optional features that were enabled.
    [[nodiscard]] const DeviceFeatures& features() const noexcept { return device_->features; }
    /// The full physical device properties, limits included.
    [[nodiscard]] const VkPhysicalDeviceProperties& properties() const noexcept { return device_->properties; }
    /// One line for logs: "llvmpipe (...) [cpu, Vulkan 1.3.230]".
    [[nodiscard]] std::string describe() const {
        return device_name() + " [" + std::string(detail::device_type_name(device_type())) + ", Vulkan " +
               detail::version_string(api_version()) + "]";
    }

    [[nodiscard]] VkInstance instance() const noexcept { return device_->instance; }               ///< Raw handle.
    [[nodiscard]] VkPhysicalDevice physical_device() const noexcept { return device_->physical; }  ///< Raw handle.
    [[nodiscard]] VkDevice device() const noexcept { return device_->device; }                     ///< Raw handle.
    [[nodiscard]] VkQueue queue() const noexcept { return device_->queue; }                        ///< Raw handle.
    /// The queue family index of queue().
    [[nodiscard]] std::uint32_t queue_family() const noexcept { return device_->queue_family; }

    /// Binds `buffers` to bindings 0..n-1 of set 0, pushes `push_bytes` bytes of constants, runs
    /// groups_x * groups_y * groups_z workgroups of `kernel` and waits for completion. Returns the
    /// GPU-side time in milliseconds from timestamp queries when supported, else host-measured.
    /// Defined in <sylva/vulkan/runner.hpp>.
    double dispatch(Kernel& kernel, std::span<Buffer* const> buffers, const void* push, std::size_t push_bytes,
                    std::uint32_t groups_x, std::uint32_t groups_y = 1, std::uint32_t groups_z = 1);

    /// The shared device state (for Buffer and Kernel).
    [[nodiscard]] const std::shared_ptr<detail::Device>& shared_device() const noexcept { return device_; }

private:
    explicit Context(std::shared_ptr<detail::Device> device) : device_(std::move(device)) {}

    std::shared_ptr<detail::Device> device_;
};

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_CONTEXT_HPP
