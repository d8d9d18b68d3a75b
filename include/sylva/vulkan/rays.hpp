// sylva/vulkan/rays.hpp -- the ray binding of the volume and isosurface kernels
// (sylva/shared/rays.h): the caller's rays uploaded for RaySource::Buffer, else a dummy.
#ifndef SYLVA_VULKAN_RAYS_HPP
#define SYLVA_VULKAN_RAYS_HPP

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "sylva/render/rays.hpp"
#include "sylva/vulkan/buffer.hpp"

namespace sylva::vk::detail {

/// The ray binding of a volume or iso kernel: the caller's rays (PixelRays::buffer, or
/// PixelRays::generate evaluated for every pixel) for RaySource::Buffer, else a 24-byte dummy
/// the shader never reads (the camera words make the rays).
inline Buffer ray_binding(Context& ctx, const CameraFrame& cam, const PixelRays& rays, std::uint32_t width,
                          std::uint32_t height) {
    if (rays.source != RaySource::Buffer) return Buffer(ctx, 24);
    std::vector<float> f = ray_buffer(cam, rays, width, height);
    std::vector<std::uint32_t> w(f.size());
    std::memcpy(w.data(), f.data(), f.size() * 4);
    Buffer b(ctx, std::max<std::size_t>(w.size(), 6) * 4);
    b.upload(w);
    return b;
}

}  // namespace sylva::vk::detail

#endif  // SYLVA_VULKAN_RAYS_HPP
