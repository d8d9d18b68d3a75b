// sylva/shared/lang.h -- the bridge that lets one text compile as C++20 and as GLSL 4.60.
//
// Rules for every header under sylva/shared/ (see docs/DESIGN.md, "The shared C++/GLSL subset"):
//  * GLSL names and semantics (uint, vec3, floatBitsToUint, ...); GLM supplies them on the host.
//  * Typed literals (1.0f, 1u); no mixed-type calls; no pointers, templates, recursion, static,
//    inline, typedef, sizeof, goto, unsigned, char, default arguments, overloaded operators,
//    swizzles, implicit bool from integers, arrays as parameters.
//  * Functions are declared `SYLVA_FN`; out-parameters `SYLVA_OUT(T)`, in-out `SYLVA_INOUT(T)`,
//    read-only structs `SYLVA_IN(T)` (a const reference in C++: an inlined by-value struct that
//    is rebuilt a sample can cost the host a store-to-load stall each read; `in T` in GLSL).
//    `SYLVA_FN_HOT` marks a small per-sample function the host compiler must inline (GCC left
//    the octree's brick sampler a call; nothing in GLSL, where every call is inlined).
//    `SYLVA_FN_APART` keeps a rarely taken path out of its caller's inlined body on the host
//    (the sparse grid sampler inlined into the dense marcher cost it 20-30 % of its speed).
//  * Buffers: a function that reads a buffer takes `SYLVA_BUF(name)` and reads with
//    `SYLVA_LOAD(name, index)`. In C++ that is a bounds-safe view over 32-bit words; in GLSL the
//    shader defines `uint sylva_load_<name>(uint i)` before including the shared header.
//    `SYLVA_LOAD_U8(name, i)` / `SYLVA_LOAD_U16(name, i)` read byte / 16-bit half i of the
//    words, little-endian (i.e. bits 8 (i & 3) of word i >> 2): a byte load on the host, a
//    shift and mask of the word in GLSL; 0 past the end. Arguments are evaluated more than
//    once in GLSL: pass a plain variable or expression without side effects.
//    The buffer is chosen by the parameter's NAME in GLSL, by its value in C++: a helper
//    declared with SYLVA_BUF(words) always reads `words` on the GPU, whatever is passed. Only
//    pass a buffer on to a helper whose parameter has the same name (the parity tests catch it).
//    `SYLVA_PREFETCH(name, i);` asks for the cache line of word i on the host (nothing past the
//    end; no effect on results) and is empty in GLSL; host-only code that reads `name.size`
//    (how many words) sits under `#ifdef __cplusplus`.
//  * Buffers a shader does not bind: `#define SYLVA_NO_<NAME>` (TF, TFSUM, PARAMS, RAYS, GRID)
//    before the first include and this header defines `sylva_load_<name>` returning 0, so a
//    shader never writes loaders for buffers it does not read (e.g. SYLVA_NO_TF with the TF hook
//    of tf.h, SYLVA_NO_PARAMS when it fills SylvaDvrParams itself, SYLVA_NO_RAYS without a ray
//    buffer). Reads of such a buffer give 0 words; the C++ side is unaffected.
//  * Bit-exact host/GPU parity: use sylva_safe_rcp, canonicalise signed zero with sylva_canon
//    (integer bit operations: lavapipe may fold `x + 0.0f`), compile host code with
//    -ffp-contract=off, no fma.
//  * User code in the subset (an element type, see sylva/shared/element.h) lives in its own
//    namespace: SYLVA_USER_BEGIN_NAMESPACE(ns) ... SYLVA_USER_END_NAMESPACE opens `namespace ns`
//    with the subset's names (uint, vec3, sylva_* helpers) visible in C++, and nothing in GLSL
//    (GLSL has one global namespace: prefix user names). SYLVA_BEGIN_NAMESPACE stays the
//    library's own (sylva::shared); do not redefine it. SYLVA_DEFAULT(v) gives a struct member a
//    default value in C++ (` = v`) and nothing in GLSL, so one struct serves both;
//    `SYLVA_UNUSED(x);` marks a parameter unused (C++ warns, GLSL does not).
//  * Host compiler flags: the shared code needs IEEE float semantics. -ffast-math (and
//    -Ofast, which implies it) is refused below with an #error, through the __FAST_MATH__
//    macro GCC and Clang define for it. -ffp-contract=off cannot be detected portably (no
//    compiler defines a macro for it), so the sylva::sylva CMake target adds it; code built
//    outside that target must pass -ffp-contract=off itself (MSVC: /fp:precise, the default),
//    or fused multiply-adds break bit-exact parity with the GPU without any error.
#ifndef SYLVA_SHARED_LANG_H
#define SYLVA_SHARED_LANG_H

#ifdef __cplusplus
#if defined(__FAST_MATH__)
#error "sylva: the shared C++/GLSL headers need IEEE float semantics: do not compile them with -ffast-math or -Ofast (they also need -ffp-contract=off, which the sylva::sylva CMake target adds; pass it yourself outside it)"
#endif
#include <bit>
#include <cstdint>
#include <cstddef>
#include <cstring>
#include <functional>
#include <glm/glm.hpp>
#include <glm/gtc/type_precision.hpp>

namespace sylva::shared {
using namespace glm;
using uint = std::uint32_t;

/// A read-only view of 32-bit words: what crosses to the GPU. Out-of-range loads return 0,
/// so corrupted encodings can never read outside the buffer on the host.
struct Words {
    const std::uint32_t* data = nullptr;
    std::size_t size = 0;
    /// Host only: the transfer-function hook (tf.h, SYLVA_TF_KIND_HOOK) a TF view carries, a
    /// callable density -> straight RGBA; null elsewhere. GLSL's hook is the shader's function.
    const std::function<glm::vec4(float)>* hook = nullptr;
    [[nodiscard]] std::uint32_t operator[](std::size_t i) const noexcept { return i < size ? data[i] : 0u; }
    /// Byte i of the words, little-endian (bits 8 (i & 3) .. of word i >> 2); 0 past the end.
    [[nodiscard]] std::uint32_t byte_at(std::size_t i) const noexcept {
        return i < size * 4 ? std::uint32_t{reinterpret_cast<const unsigned char*>(data)[i]} : 0u;
    }
    /// A hint that word i will be read soon (the cache line that holds it); nothing past the end.
    void prefetch(std::size_t i) const noexcept {
        if (i >= size) return;
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
        // Not __builtin_prefetch: GCC deletes a loop whose body only prefetches (no side effects).
        asm volatile("prefetcht0 %0" : : "m"(*reinterpret_cast<const char*>(data + i)));
#else
        __builtin_prefetch(data + i);
#endif
    }
    /// 16-bit half i of the words, little-endian (bits 16 (i & 1) .. of word i >> 1); 0 past the end.
    [[nodiscard]] std::uint32_t half_at(std::size_t i) const noexcept {
        if (i >= size * 2) return 0u;
        std::uint16_t h;
        std::memcpy(&h, reinterpret_cast<const unsigned char*>(data) + 2 * i, 2);
        return h;
    }
};
static_assert(std::endian::native == std::endian::little,
              "sylva: byte_at / half_at read the words' bytes as the GPU does (little endian)");
}  // namespace sylva::shared

#define SYLVA_BEGIN_NAMESPACE namespace sylva::shared {
#define SYLVA_END_NAMESPACE }
#define SYLVA_FN inline
#define SYLVA_FN_HOT [[gnu::always_inline]] inline
#define SYLVA_FN_APART [[gnu::noinline]] inline
#define SYLVA_OUT(T) T&
#define SYLVA_INOUT(T) T&
#define SYLVA_IN(T) const T&
#define SYLVA_BUF(name) const ::sylva::shared::Words& name
#define SYLVA_LOAD(name, i) (name)[(i)]
#define SYLVA_LOAD_U8(name, i) (name).byte_at(i)
#define SYLVA_LOAD_U16(name, i) (name).half_at(i)
#define SYLVA_PREFETCH(name, i) (name).prefetch(i)
#define SYLVA_PASS_BUF(name) name
#define SYLVA_PRECISE
#define SYLVA_CONST constexpr
#define SYLVA_USER_BEGIN_NAMESPACE(ns) \
    namespace ns {                     \
    using namespace ::sylva::shared;
#define SYLVA_USER_END_NAMESPACE }
#define SYLVA_DEFAULT(v) = v
#define SYLVA_UNUSED(x) static_cast<void>(x)

#else  // GLSL

#define SYLVA_BEGIN_NAMESPACE
#define SYLVA_END_NAMESPACE
#define SYLVA_FN
#define SYLVA_FN_HOT
#define SYLVA_FN_APART
#define SYLVA_OUT(T) out T
#define SYLVA_INOUT(T) inout T
#define SYLVA_IN(T) in T
#define SYLVA_BUF(name) uint name
#define SYLVA_LOAD(name, i) sylva_load_##name(i)
#define SYLVA_LOAD_U8(name, i) ((sylva_load_##name((i) >> 2u) >> (((i) & 3u) * 8u)) & 255u)
#define SYLVA_LOAD_U16(name, i) ((sylva_load_##name((i) >> 1u) >> (((i) & 1u) * 16u)) & 65535u)
#define SYLVA_PREFETCH(name, i)
#define SYLVA_PASS_BUF(name) 0u
#define SYLVA_PRECISE precise
#define SYLVA_CONST const
#define SYLVA_USER_BEGIN_NAMESPACE(ns)
#define SYLVA_USER_END_NAMESPACE
#define SYLVA_DEFAULT(v)
#define SYLVA_UNUSED(x)

#ifdef SYLVA_NO_TF
uint sylva_load_tf(uint i) { return 0u; }
#endif
#ifdef SYLVA_NO_TFSUM
uint sylva_load_tfsum(uint i) { return 0u; }
#endif
#ifdef SYLVA_NO_PARAMS
uint sylva_load_params(uint i) { return 0u; }
#endif
#ifdef SYLVA_NO_RAYS
uint sylva_load_rays(uint i) { return 0u; }
#endif
#ifdef SYLVA_NO_GRID
uint sylva_load_grid(uint i) { return 0u; }
#endif

#endif

SYLVA_BEGIN_NAMESPACE

/// +infinity as a bit pattern, identical on both targets.
SYLVA_FN float sylva_inf() { return uintBitsToFloat(0x7f800000u); }

/// Minimum and maximum that never depend on how a target treats NaN or signed zero:
/// callers guarantee non-NaN arguments; ties return the first argument.
SYLVA_FN float sylva_min(float a, float b) { return (b < a) ? b : a; }
SYLVA_FN float sylva_max(float a, float b) { return (b > a) ? b : a; }

/// 1/x, with +0 and -0 mapped to +inf and -inf (IEEE semantics written out, so no target
/// ever multiplies 0 by inf or flushes the sign).
SYLVA_FN float sylva_safe_rcp(float x) {
    if (x == 0.0f) {
        return ((floatBitsToUint(x) & 0x80000000u) != 0u) ? -sylva_inf() : sylva_inf();
    }
    return 1.0f / x;
}

/// Canonicalises -0 to +0 so both targets report identical bits. Written with integer bit
/// operations: `x + 0.0f`, even `precise`, was folded to x by lavapipe in some shaders (the
/// implicit kd-tree's parity test saw -0 on the device, +0 on the host).
SYLVA_FN float sylva_canon(float x) {
    uint b = floatBitsToUint(x);
    return uintBitsToFloat((b == 0x80000000u) ? 0u : b);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_LANG_H
