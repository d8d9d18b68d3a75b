// sylva/vulkan/detail/spirv_check.hpp -- a host-side structural check of SPIR-V before it reaches
// the driver, so that a truncated or mismatched module becomes a sylva::Error, not a crash.
#ifndef SYLVA_VULKAN_DETAIL_SPIRV_CHECK_HPP
#define SYLVA_VULKAN_DETAIL_SPIRV_CHECK_HPP

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/vulkan/detail/device.hpp"

namespace sylva::vk::detail {

inline constexpr std::uint32_t spirv_magic = 0x07230203u;
inline constexpr std::uint32_t spirv_op_entry_point = 15u;
inline constexpr std::uint32_t spirv_op_decorate = 71u;
inline constexpr std::uint32_t spirv_decoration_binding = 33u;
inline constexpr std::uint32_t spirv_decoration_descriptor_set = 34u;
inline constexpr std::uint32_t spirv_execution_model_glcompute = 5u;

/// What the check learned about a module.
struct SpirvFacts {
    std::uint32_t version_minor = 0;                  ///< SPIR-V 1.<minor>.
    bool has_compute_main = false;                    ///< An OpEntryPoint GLCompute "main".
    std::map<std::uint32_t, std::uint32_t> bindings;  ///< Variable id -> Binding decoration.
    std::map<std::uint32_t, std::uint32_t> sets;      ///< Variable id -> DescriptorSet decoration.
};

/// "0x07230203" for messages.
inline std::string hex_word(std::uint32_t word) {
    static constexpr char digits[] = "0123456789abcdef";
    std::string text = "0x";
    for (int shift = 28; shift >= 0; shift -= 4) text += digits[(word >> shift) & 0xfu];
    return text;
}

/// The Vulkan version that must be present to consume SPIR-V 1.<minor>.
inline std::uint32_t vulkan_for_spirv(std::uint32_t minor) noexcept {
    if (minor <= 3) return VK_API_VERSION_1_1;
    if (minor <= 5) return VK_API_VERSION_1_2;
    return VK_API_VERSION_1_3;
}

/// Whether the literal string starting at words[at] within an instruction ending at `end` is "main".
inline bool literal_is_main(std::span<const std::uint32_t> words, std::size_t at, std::size_t end) noexcept {
    // "main\0" packs little-endian into 0x6e69616d followed by a word whose low byte is 0.
    return at + 1 < end && words[at] == 0x6e69616du && (words[at + 1] & 0xffu) == 0u;
}

/// Records the facts one instruction contributes.
inline void note_instruction(std::span<const std::uint32_t> words, std::size_t at, std::size_t count,
                             SpirvFacts& facts) {
    const std::uint32_t opcode = words[at] & 0xffffu;
    if (opcode == spirv_op_entry_point && count >= 4 && words[at + 1] == spirv_execution_model_glcompute &&
        literal_is_main(words, at + 3, at + count)) {
        facts.has_compute_main = true;
    }
    if (opcode == spirv_op_decorate && count >= 4) {
        if (words[at + 2] == spirv_decoration_binding) facts.bindings[words[at + 1]] = words[at + 3];
        if (words[at + 2] == spirv_decoration_descriptor_set) facts.sets[words[at + 1]] = words[at + 3];
    }
}

/// Reads the header and walks every instruction; throws sylva::Error on malformed input.
inline SpirvFacts read_spirv_facts(std::span<const std::uint32_t> words) {
    if (words.size() < 5) {
        throw Error("invalid SPIR-V: " + std::to_string(words.size()) + " words is shorter than the 5-word header");
    }
    if (words[0] != spirv_magic) {
        throw Error("invalid SPIR-V: magic number " + hex_word(words[0]) + " is not 0x07230203");
    }
    const std::uint32_t major = (words[1] >> 16) & 0xffu;
    SpirvFacts facts;
    facts.version_minor = (words[1] >> 8) & 0xffu;
    if (major != 1 || facts.version_minor > 6) {
        throw Error("invalid SPIR-V: unknown version " + std::to_string(major) + "." +
                    std::to_string(facts.version_minor));
    }
    for (std::size_t at = 5; at < words.size();) {
        const std::size_t count = words[at] >> 16;
        if (count == 0 || at + count > words.size()) {
            throw Error("invalid SPIR-V: instruction at word " + std::to_string(at) + " has length " +
                        std::to_string(count) + " in a module of " + std::to_string(words.size()) + " words");
        }
        note_instruction(words, at, count, facts);
        at += count;
    }
    return facts;
}

/// Throws sylva::Error unless `words` is a well-formed compute module whose resources all sit in
/// descriptor set 0 at bindings below `binding_count`, consumable by a device of `api_version`.
inline void check_spirv(std::span<const std::uint32_t> words, std::uint32_t binding_count, std::uint32_t api_version) {
    const SpirvFacts facts = read_spirv_facts(words);
    if (vulkan_for_spirv(facts.version_minor) > api_version) {
        throw Error("SPIR-V 1." + std::to_string(facts.version_minor) + " needs Vulkan " +
                    version_string(vulkan_for_spirv(facts.version_minor)) + ", the device has " +
                    version_string(api_version));
    }
    if (!facts.has_compute_main) throw Error("SPIR-V has no GLCompute entry point named main");
    for (const auto& [id, binding] : facts.bindings) {
        const auto set = facts.sets.find(id);
        if (set != facts.sets.end() && set->second != 0) {
            throw Error("SPIR-V uses descriptor set " + std::to_string(set->second) +
                        "; sylva kernels bind set 0 only");
        }
        if (binding >= binding_count) {
            throw Error("SPIR-V uses binding " + std::to_string(binding) + " but the kernel declares " +
                        std::to_string(binding_count) + " storage buffers");
        }
    }
}

}  // namespace sylva::vk::detail

#endif  // SYLVA_VULKAN_DETAIL_SPIRV_CHECK_HPP
