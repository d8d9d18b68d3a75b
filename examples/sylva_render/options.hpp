// sylva-render's command line (parsed by CLI11 in options.cpp; --help prints usage()).
#ifndef SYLVA_RENDER_OPTIONS_HPP
#define SYLVA_RENDER_OPTIONS_HPP

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <sylva/ikd/build.hpp>
#include <sylva/volume/value_range.hpp>

namespace sylva_render {

struct Options {
    std::string particles;           ///< --particles FILE (float32 xyz triples)
    std::string volume;              ///< --volume FILE|procedural[:NAME] (.raw by name convention, .nrrd, .nhdr)
    std::string index = "bih";       ///< --index bih|kd-vidal|kd-binned|implicit-kd|dda|octree|none (none: the reference
                                     ///< marcher, volumes only; kd-*: the marcher with empty-space skipping by a
                                     ///< kd-tree; implicit-kd: exact isosurfaces over Wald's implicit kd-tree,
                                     ///< dda: the same over every cell (the reference); octree: Gobbetti's
                                     ///< bricked octree, DVR or first-hit iso, for volumes; the element
                                     ///< octree for --particles or --count (cpu or vulkan))
    std::uint32_t animate = 0;       ///< --animate N: move the particles for N frames (animation_scene.hpp)
    std::string update = "refit";    ///< --update refit|rebuild: how the index follows the motion per frame
    /// --order exact|leaf (particles): exact = every --index through the generic element kernel
    /// (sylva/render/elements.hpp; (t0, index) order, the same image from bih, kd and octree);
    /// leaf = each index's own particle integrator (the BIH's per-leaf sort, Kinkelin 4.2)
    std::string order = "exact";
    std::uint32_t brick = 32;        ///< --brick 16|32: octree brick size
    float lod_pixels = 0.0f;         ///< --lod-pixels P: view-dependent octree cut (0: full resolution)
    std::uint32_t cut_nodes = 1u << 20;  ///< --cut-nodes N: node budget of the octree cut
    float max_tf_error = 1.0f / 64.0f;   ///< --max-tf-error E: the cut's TF-aware refinement (octree::CutConfig)
    std::string mode;                ///< --mode dvr|iso (volumes, default dvr; implies a procedural volume without input)
    std::string dvr = "single";      ///< --dvr single|multi: BIH-DVR samples per leaf (Kinkelin 4.3)
    std::string tf;                  ///< --tf FILE (.json or text control points)
    std::string tf_preset = "ct";    ///< --tf-preset ct|ramp
    float threshold = 0.1f;          ///< --threshold D: voxels with normalised density >= D are elements
    std::string border = "zero";     ///< --border clamp|zero: what grid samples read outside the voxel centres
    std::string grid_format = "native";  ///< --grid native|sparse|float32: uint8 / uint16 files read as stored (1 / 2 bytes a voxel), in 8^3 bricks (uniform ones held in the brick table), or a float copy
    float resample = 1.0f;           ///< --resample F: trilinear supersampling factor (Kinkelin 6.2)
    std::optional<std::vector<float>> spacing;  ///< --spacing X,Y,Z: voxel size override
    /// --range auto|type|LO,HI: the raw values that map to density 0 and 1 (volume files; auto:
    /// the file's min/max fields, else the data's min/max; sylva/volume/value_range.hpp)
    sylva::volume::ValueRange range;
    float lod_density = 0.75f;       ///< --lod-density F: min element density of an LoD leaf (Table 3)
    float lod_stddev = 0.01f;        ///< --lod-stddev F: max std-dev of an LoD leaf's densities (Table 3)
    std::uint32_t lod_depth = 64;    ///< --lod-depth N: max LoD depth
    float iso = 0.5f;                ///< --iso V: iso value for --mode iso (the first of --iso V1,V2,...)
    std::vector<float> isos{0.5f};   ///< --iso V1[,V2,...]: up to 4 isovalues (implicit-kd, dda)
    std::uint32_t ikd_bricks = sylva::ikd::Config{}.brick_levels;  ///< --ikd-bricks N: bottom levels of the implicit kd-tree not stored (0: slim tree)
    std::uint32_t ikd_node_bits = sylva::ikd::Config{}.node_bits;  ///< --ikd-node-bits 8|16: bits of a node's min and max (ikd::Config::node_bits)
    std::uint32_t packets = 8;  ///< --packets 1|4|8|16: rays walking the implicit kd-tree together on the host (1: single rays)
    bool iso_cull = true;            ///< --iso-cull on|off: skip nodes whose density range excludes V
    std::uint32_t steps = 1024;      ///< --steps N: samples along the longest axis (reference marcher, multi)
    bool shading = false;            ///< --shading: Lambert shading from the gradient
    std::string backend = "cpu";     ///< --backend cpu|vulkan
    std::string camera = "pinhole";  ///< --camera pinhole|ortho: the volume renderers' primary rays
    std::uint32_t width = 960, height = 720;
    std::string output;              ///< -o OUT.png|OUT.exr
    std::string stats_json;          ///< --stats-json FILE
    std::string heatmap;             ///< --heatmap FILE
    std::size_t count = 1000000;     ///< --count N: particles of the procedural galaxy
    bool count_given = false;        ///< --count was given: with --index octree and no input, the galaxy
    float radius_factor = 0.25f;     ///< --radius-factor F: radius in mean spacings (files)
    float opacity = 0.12f;           ///< --opacity A (files)
    float alpha_stop = 0.99f;        ///< --alpha-stop A: early ray termination
    std::string payload = "inline";  ///< --payload inline|range
    std::string nodes = "fixed16";   ///< --nodes fixed16|float32
    std::string layout = "chunks";   ///< --layout chunks|preorder
    std::uint32_t chunk_depth = 2;   ///< --chunk-depth D
    std::string empty_children = "trim-both";  ///< --empty-children trim-both|infinite
    std::uint32_t threads = 0;       ///< --threads T (0: all cores)
    std::optional<std::vector<float>> view;    ///< --view X,Y,Z: direction from the centre to the eye
    bool quiet = false;              ///< --quiet
    std::string kd = "deep";         ///< --kd shallow|deep: Vidal's halting criteria or Zellmann's 8^3 leaves
    std::string kd_classify = "alpha";  ///< --kd-classify alpha|threshold: occupancy from the TF's alpha or --threshold
    std::string boxes;               ///< --boxes FILE: the rendering with the kd-tree's leaf boxes drawn over it
    std::vector<std::string> tf_sequence;  ///< --tf-sequence F1,F2,...: replay TFs, rebuild the kd-tree for each
    std::uint32_t repeat = 1;        ///< --repeat N: render N frames (volumes, most particle runs), report the fastest
    // Out of core (--index octree; issue 13, ooc_scene.hpp): progressive frames through the
    // host cache, the loader and the device pool; a brick store (--volume DIR made by
    // sylva-store build) always renders this way.
    std::size_t memory_budget = std::size_t{256} << 20;  ///< --memory-budget SIZE: host brick cache (K, M, G suffixes)
    std::size_t device_budget = std::size_t{128} << 20;  ///< --device-budget SIZE: device brick pool
    std::uint32_t frames = 0;        ///< --frames N: progressive frames (0: in core; a store: 32)
    std::string frames_out;          ///< --frames-out DIR: every frame as DIR/frame_NNNN.png
    bool orbit = false;              ///< --orbit: the view turns once about the vertical axis over the frames
    bool feedback = true;            ///< --feedback on|off: refine only nodes rays reached the frame before

    /// True for the kd-tree indices (--index kd-vidal|kd-binned).
    [[nodiscard]] bool kd_index() const { return index == "kd-vidal" || index == "kd-binned"; }
    /// True for the bricked octree (--index octree).
    [[nodiscard]] bool octree_index() const { return index == "octree"; }
    /// True for the exact isosurface indices (--index implicit-kd|dda).
    [[nodiscard]] bool ikd_index() const { return index == "implicit-kd" || index == "dda"; }

    /// True for the out-of-core octree path (--frames, a budget or --frames-out given, or a store).
    [[nodiscard]] bool out_of_core() const { return octree_index() && frames > 0; }
    /// True when the volume is one of the procedural ones (no file).
    [[nodiscard]] bool procedural_volume() const { return volume.empty() || volume.rfind("procedural", 0) == 0; }

    /// True when this run renders a volume (a file, or the procedural volume for --mode or a
    /// kd-tree index).
    [[nodiscard]] bool volume_input() const {
        return !volume.empty() ||
               ((!mode.empty() || kd_index() || ikd_index() || (octree_index() && !count_given)) && particles.empty());
    }
    /// True when this run renders particles (a file or the procedural galaxy) through the
    /// element octree (--index octree with --particles, or with --count and no input).
    [[nodiscard]] bool particle_octree() const { return octree_index() && !volume_input(); }
    /// True when this run renders particles through the element kd-tree (--index kd).
    [[nodiscard]] bool particle_kd() const { return index == "kd" && !volume_input(); }
};

/// Why --order leaf --index kd --backend vulkan is refused (still or --animate): the kd-tree's
/// own particle integrator has no compute shader; --order exact draws --index kd on Vulkan.
inline constexpr const char* leaf_kd_host_only =
    "--order leaf --index kd renders particles on --backend cpu only (the kd-tree's own integrator, "
    "sylva/shared/kd_elem_particles.h, has no Vulkan kernel; --order exact, the default, renders --index kd on "
    "Vulkan through the generic element kernel)";

/// Parses argv through CLI11 (options.cpp), then checks the options against each other; throws
/// std::invalid_argument with a message naming the bad option.
Options parse(int argc, char** argv);
/// The --help text (CLI11's, the options grouped by what they apply to).
std::string usage();

}  // namespace sylva_render

#endif
