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

/// The grid words the marcher and ESS DVR read (--border, --grid): with --grid native a density
/// grid whose every value is exactly v / 255 for a byte v (uint8 data over 0..255, not
/// resampled) goes back to 1 byte a voxel (GridWords::native; verified value by value, else the
/// float words); --grid sparse the same bytes in 8^3 bricks, uniform ones held in the brick
/// table (GridWords::sparse); the stats get grid_bytes, grid_format and border.
sylva::GridWords render_grid(const Options& o, const sylva::volume::DensityGrid& g, Stats& s);

/// Reads a transfer-function file (.json, else text control points; sylva/volume/transfer_function.hpp).
sylva::volume::TransferFunction read_tf_file(const std::string& path);

}  // namespace sylva_render

#endif
