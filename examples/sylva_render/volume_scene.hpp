// sylva-render, volume input: load or generate a density grid, build the full BIH over its
// voxel cuboids and the default LoD (Kinkelin sections 4.3, 5.2, 6.1), and render it with the
// reference marcher or BIH-DVR on the host or through Vulkan.
#ifndef SYLVA_RENDER_VOLUME_SCENE_HPP
#define SYLVA_RENDER_VOLUME_SCENE_HPP

#include <string>

#include <sylva/volume/transfer_function.hpp>

#include "options.hpp"
#include "stats.hpp"

namespace sylva_render {

/// Runs one volume render as `o` says; returns the process exit status.
int run_volume(const Options& o);

/// Reads a transfer-function file (.json, else text control points; sylva/volume/transfer_function.hpp).
sylva::volume::TransferFunction read_tf_file(const std::string& path);

}  // namespace sylva_render

#endif
