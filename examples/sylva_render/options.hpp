// sylva-render command line.
#ifndef SYLVA_RENDER_OPTIONS_HPP
#define SYLVA_RENDER_OPTIONS_HPP

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sylva_render {

struct Options {
    std::string particles;           ///< --particles FILE (float32 xyz triples)
    std::string volume;              ///< --volume FILE (not in this release)
    std::string index = "bih";       ///< --index bih
    std::string backend = "cpu";     ///< --backend cpu|vulkan
    std::uint32_t width = 960, height = 720;
    std::string output;              ///< -o OUT.png|OUT.exr
    std::string stats_json;          ///< --stats-json FILE
    std::string heatmap;             ///< --heatmap FILE
    std::size_t count = 1000000;     ///< --count N: particles of the procedural galaxy
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
};

/// Parses argv; throws std::invalid_argument with a message naming the bad option.
Options parse(int argc, char** argv);
/// The usage text.
const char* usage();

}  // namespace sylva_render

#endif
