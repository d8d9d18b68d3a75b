// sylva/vulkan/tf.hpp -- the transfer-function binding of the volume kernels (sylva/shared/tf.h):
// the RGBA8 table or the float RGBA table's bits; the hook kind has no table (a 4-byte dummy) and
// needs a kernel whose shader defines sylva_tf_user.
#ifndef SYLVA_VULKAN_TF_HPP
#define SYLVA_VULKAN_TF_HPP

#include <cstdint>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/vulkan/buffer.hpp"

namespace sylva::vk::detail {

/// The `tf` buffer for p. TfKind::Hook throws sylva::Error unless `user_kernel` (the caller's
/// shader, which defines the GLSL hook) renders it: the library's shaders carry no hook.
inline Buffer tf_binding(Context& ctx, const VolumeRenderParams& p, bool user_kernel = false) {
    if (p.tf_kind == TfKind::Hook && !user_kernel)
        throw Error("vk: TfKind::Hook runs in your shader: define SYLVA_TF_USER and sylva_tf_user (sylva/shared/tf.h), "
                    "include sylva/shared/dvr_main.glsl and pass your kernel to vk::render_dvr_vulkan");
    TfWords t = tf_words(p);
    Buffer b(ctx, t.words.size() * 4);
    b.upload(t.words);
    return b;
}

}  // namespace sylva::vk::detail

#endif  // SYLVA_VULKAN_TF_HPP
