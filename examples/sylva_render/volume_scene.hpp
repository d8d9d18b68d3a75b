// sylva-render, volume input: load or generate a density grid, build the full BIH over its
// voxel cuboids and the default LoD (Kinkelin sections 4.3, 5.2, 6.1), and render it with the
// reference marcher or BIH-DVR on the host or through Vulkan.
#ifndef SYLVA_RENDER_VOLUME_SCENE_HPP
#define SYLVA_RENDER_VOLUME_SCENE_HPP

#include <cstdint>
#include <ostream>
#include <string>

#include <sylva/render/particles.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/transfer_function.hpp>

#include "options.hpp"
#include "stats.hpp"

namespace sylva_render {

/// Runs one volume render as `o` says; returns the process exit status.
int run_volume(const Options& o);

/// A frame of `width` x `height` fully transparent pixels and no iterator steps: what a volume
/// with nothing to traverse renders to.
sylva::Frame blank_frame(std::uint32_t width, std::uint32_t height);

/// When the rendering shows nothing (no pixel with alpha >= 1/255), says so on `err` with the
/// value range, the volume's density span, the threshold or iso value, where the transfer
/// function becomes visible, and what to change. Not an error: the caller still exits 0.
void warn_if_nothing_visible(const Options& o, const Stats& s, const sylva::volume::DensityGrid& g,
                             const sylva::VolumeRenderParams& p, std::ostream& err);

/// The grid words the marcher, the ESS DVR and the implicit kd-tree read (--border, --grid):
/// with --grid native the file's uint8 / uint16 voxels as read (`raw`: 1 / 2 bytes a voxel,
/// GridWords::native, normalised on the fly to the densities of `g`); --grid sparse the same in
/// 8^3 bricks, uniform ones held in the brick table (GridWords::sparse); else, and for
/// procedural, float32 or resampled volumes (raw null), the float words of `g`. The stats get
/// grid_bytes, grid_format (uint8, uint16, sparse-uint8, ..., float32) and border.
/// The samplers' border mode of --border: clamp, or zero (a constant 0, the default).
inline sylva::GridBorder grid_border(const Options& o) {
    return o.border == "clamp" ? sylva::GridBorder::clamp() : sylva::GridBorder{};
}

sylva::GridWords render_grid(const Options& o, const sylva::volume::DensityGrid& g, const sylva::volume::Volume* raw,
                             Stats& s);

/// Reads a transfer-function file (.json, else text control points; sylva/volume/transfer_function.hpp).
sylva::volume::TransferFunction read_tf_file(const std::string& path);

}  // namespace sylva_render

#endif
