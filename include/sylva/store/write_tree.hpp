// sylva/store/write_tree.hpp -- stores an in-core octree (octree::build) as a brick store: for
// volumes that fit in memory, and for tests of everything that reads stores. Volumes that do not
// fit go through the streamed builder (sylva/store/stream_build.hpp), which writes the same store.
#ifndef SYLVA_STORE_WRITE_TREE_HPP
#define SYLVA_STORE_WRITE_TREE_HPP

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "sylva/octree/build.hpp"
#include "sylva/octree/encode.hpp"
#include "sylva/store/codec.hpp"
#include "sylva/store/format.hpp"
#include "sylva/store/writer.hpp"

namespace sylva::store {

/// The BuildInfo of an in-core tree (input named `input`, densities of unknown origin: value
/// range [0, 1], voxel type float32; bricks in the tree's format).
inline BuildInfo build_info_of(const octree::Tree& t, std::string input, Codec codec, int level) {
    BuildInfo b;
    b.input = std::move(input);
    b.dims = t.dims;
    b.spacing = t.spacing;
    b.brick_size = t.brick_size;
    b.border = t.border;
    b.levels = t.levels;
    b.node_count = static_cast<std::uint32_t>(t.nodes.size());
    b.codec = codec;
    b.level = codec == Codec::zstd ? level : 0;
    b.brick_format = t.format;
    return b;
}

/// Writes `t` as a new store at `path` (which must not exist). Every node of a volume octree has
/// a brick and brick key n is node n's (octree::build numbers them so).
inline void write_tree(const octree::Tree& t, const std::filesystem::path& path, const BuildInfo& info,
                       const WriterConfig& cfg = {}) {
    if (t.format != info.brick_format)
        throw Error(std::string("store::write_tree: the tree's bricks are ") + brick_format_name(t.format) +
                    ", the build info says " + brick_format_name(info.brick_format));
    if (t.brick_count() != t.nodes.size()) throw Error("store::write_tree: the tree does not have one brick per node");
    StoreWriter w = StoreWriter::create(path, info, false, cfg);
    std::vector<std::byte> enc;
    const std::size_t words = t.brick_words();
    for (std::size_t b = 0; b < t.brick_count(); ++b) {
        encode_brick(std::span<const std::uint32_t>(t.bricks.data() + b * words, words), info.codec, info.level, enc);
        w.put(static_cast<std::uint32_t>(b), enc);
    }
    std::vector<std::uint32_t> index = octree::encode(t, SYLVA_OCT_BRICK_HOST);
    w.finish(index);
}

/// write_tree with the BuildInfo of build_info_of(t, "in-core octree", codec, level).
inline void write_tree(const octree::Tree& t, const std::filesystem::path& path, Codec codec = Codec::zstd,
                       int level = 1) {
    write_tree(t, path, build_info_of(t, "in-core octree", codec, level));
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_WRITE_TREE_HPP
