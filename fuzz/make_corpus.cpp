// fuzz_make_corpus OUTDIR: writes the seed corpora of the fuzz targets into OUTDIR/<target>/
// (committed as fuzz/corpus/). Structures: encodings of small built trees in the harnesses'
// input layouts (fuzz/harness/structures.hpp), so mutations start from valid encodings. Readers:
// small well-formed files of each kind (the formats of tests/volume and tests/unit).
// Deterministic; a few KB per target.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <span>
#include <string>
#include <vector>

#if SYLVA_HAVE_ZLIB
#include <zlib.h>
#endif

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/elements/sphere.hpp>
#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/occupancy.hpp>
#include <sylva/volume/voxels.hpp>

using namespace sylva;
namespace fs = std::filesystem;

namespace {

fs::path out_root;

void write(const std::string& target, const std::string& name, const std::string& bytes) {
    fs::create_directories(out_root / target);
    std::ofstream(out_root / target / name, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string bytes_of(const std::vector<std::uint32_t>& w) {
    return std::string(reinterpret_cast<const char*>(w.data()), w.size() * 4);
}
template <class T>
std::string bytes_of(const std::vector<T>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
std::string word(std::uint32_t w) { return bytes_of(std::vector<std::uint32_t>{w}); }

std::vector<Sphere> spheres(std::size_t n, std::uint32_t seed, bool clustered) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::normal_distribution<float> g(0.0f, 0.05f);
    std::vector<Sphere> out;
    for (std::size_t i = 0; i < n; ++i) {
        vec3 c = clustered ? vec3(float(i % 3) * 0.4f) + vec3(g(rng), g(rng), g(rng)) : vec3(u(rng), u(rng), u(rng));
        out.push_back({c, 0.02f + 0.05f * u(rng), vec4(0.8f, 0.6f, 0.3f, 0.4f), 2.0f});
    }
    return out;
}

volume::DensityGrid blobs(volume::Dims d, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    vec3 c0(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
    float r = 0.4f * float(std::max({d.x, d.y, d.z}));
    volume::DensityGrid g{d, vec3(1.0f, 1.0f, 1.5f), std::vector<float>(volume::voxel_count(d))};
    for (std::uint32_t z = 0; z < d.z; ++z)
        for (std::uint32_t y = 0; y < d.y; ++y)
            for (std::uint32_t x = 0; x < d.x; ++x) {
                vec3 p(x, y, z);
                float v = std::exp(-glm::dot(p - c0, p - c0) / (r * r));
                g.values[volume::voxel_index(d, x, y, z)] = std::clamp(0.8f * v + 0.2f * u(rng), 0.0f, 1.0f);
            }
    return g;
}

void structures() {
    // BIH: [element count, words], the node formats and layouts of tests/unit/test_bih_iter.cpp.
    for (bool clustered : {false, true}) {
        auto es = spheres(40, clustered ? 3 : 1, clustered);
        std::span<const Sphere> s(es);
        bih::Config infinite;
        infinite.empty_children = bih::EmptyChildren::Infinite;
        struct V { const char* name; bih::Config b; bih::EncodeConfig e; };
        for (const V& v : {V{"fixed16_chunks", {}, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2}},
                           V{"float32_preorder", infinite, {bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}}}) {
            auto words = bih::encode(bih::build(s, v.b), s, bih::RangePayload{}, v.e);
            write("bih", std::string(clustered ? "clustered_" : "uniform_") + v.name, word(std::uint32_t(es.size())) + bytes_of(words));
        }
    }
    // LoD: the encoded LoD of a small blobby volume (tests/lod/test_lod_encode.cpp).
    for (std::uint32_t chunk : {0u, 2u}) {
        auto g = blobs({10, 8, 6}, 5 + chunk);
        auto cuboids = volume::voxel_cuboids(g, 0.1f);
        bih::FullBih full = bih::build_full(cuboids, {});
        bih::LodConfig lc;
        lc.chunk_depth = chunk;
        write("lod", "blobs_chunk" + std::to_string(chunk), bytes_of(bih::encode_lod(bih::extract_lod(full, lc), lc)));
    }
    // kd-tree over the occupancy of a few balls and a rod (tests/kd/reference.hpp's shapes).
    for (std::uint32_t seed : {1u, 2u}) {
        volume::Dims d{14, 11, 9};
        volume::Occupancy o{d, vec3(1.0f, 1.0f, 1.5f), std::vector<std::uint8_t>(volume::voxel_count(d))};
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int k = 0; k < 3; ++k) {
            vec3 c(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
            float r = 1.0f + u(rng) * 2.5f;
            for (std::uint32_t z = 0; z < d.z; ++z)
                for (std::uint32_t y = 0; y < d.y; ++y)
                    for (std::uint32_t x = 0; x < d.x; ++x) {
                        vec3 p = vec3(x, y, z) + 0.5f - c;
                        bool in = k == 2 ? (std::abs(p.y) < 1.0f && std::abs(p.z) < 1.5f) : glm::dot(p, p) < r * r;
                        if (in) o.voxels[volume::voxel_index(d, x, y, z)] = 1u;
                    }
        }
        write("kd", "balls_rod" + std::to_string(seed), bytes_of(kdtree::encode(kdtree::build_vidal(o, kdtree::Config::deep()))));
    }
    // Implicit kd-tree: [index words N, index, grid words].
    for (std::uint32_t levels : {0u, 3u}) {
        auto g = blobs({8, 5, 4}, 9);
        auto words = ikd::encode(ikd::build(g, ikd::Config{levels}));
        auto grid = GridWords::from(g).words;
        write("ikd", "blobs_levels" + std::to_string(levels), word(std::uint32_t(words.size())) + bytes_of(words) + bytes_of(grid));
    }
    // Bricked octree: [index words N, index, bricks], 4^3 bricks with a 1-voxel border.
    {
        auto g = blobs({9, 8, 6}, 13);
        octree::Config cfg;
        cfg.brick_size = 4;
        cfg.border = 1;
        octree::Tree t = octree::build(g, cfg);
        auto words = octree::encode(t);
        write("octree", "blobs_b4", word(std::uint32_t(words.size())) + bytes_of(words) + bytes_of(t.bricks));
    }
    // Element octree: [element count, words].
    for (bool clustered : {false, true}) {
        auto es = spheres(60, 7, clustered);
        octree::ElementConfig cfg;
        if (clustered) cfg.leaf_elements = 2;
        auto words = octree::encode_elements(octree::build_elements(std::span<const Sphere>(es), cfg));
        write("octree_elements", clustered ? "clustered" : "uniform", word(std::uint32_t(es.size())) + bytes_of(words));
    }
}

#if SYLVA_HAVE_ZLIB
std::string gzip(const std::string& raw) {
    z_stream z{};
    deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
    std::string out(deflateBound(&z, static_cast<uLong>(raw.size())) + 32, '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
    z.avail_in = static_cast<uInt>(raw.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    deflate(&z, Z_FINISH);
    out.resize(z.total_out);
    deflateEnd(&z);
    return out;
}
#endif

std::string ramp(std::size_t n, std::size_t width) {
    std::string s;
    for (std::size_t i = 0; i < n * width; ++i) s += char((i * 37 + 11) & 0xFF);
    return s;
}

void readers() {
    for (const char* n : {"lobster_301x324x56_uint8.raw", "4x4x4_uint8.raw", "a_1x2x3_float32.RAW", "dir/b_7x1x1_uint16.raw",
                          "c_4294967295x2x2_uint8.raw"})
        write("raw_name", std::string(n).find('/') != std::string::npos ? "with_dir" : n, n);
    write("raw", "u8", "a_4x3x2_uint8.raw\n" + ramp(24, 1));
    write("raw", "u16", "b_3x2x2_uint16.raw\n" + ramp(12, 2));
    std::vector<float> f{0.0f, 1.5f, -2.0f, 3.0f, 0.25f, 8.0f, 1e3f, 0.5f};
    write("raw", "f32", "c_2x2x2_float32.raw\n" + bytes_of(f));
    const std::string u8 = "NRRD0004\n# a comment\ntype: uchar\ndimension: 3\nsizes: 2 3 4\nencoding: raw\n";
    write("raw", "nrrd_by_extension", "v.nrrd\n" + u8 + "\n" + ramp(24, 1));

    write("nrrd_attached", "u8", u8 + "spacings: 1 1 2\nkey:=value\n\n" + ramp(24, 1));
    write("nrrd_attached", "u16_big",
          "NRRD0005\ntype: unsigned short\ndimension: 3\nsizes: 2 3 4\nencoding: raw\nendian: big\nmin: 0\nmax: 4000\n\n" + ramp(24, 2));
    write("nrrd_attached", "float_directions",
          "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\nspace: left-posterior-superior\n"
          "space directions: (0.5,0,0) (0,0.5,0) (0,0,1.5)\nspace origin: (1,2,3)\n\n" + bytes_of(f));
    write("nrrd_attached", "short_skip",
          "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\nendian: little\nbyte skip: 4\n\nSKIP" + ramp(12, 2));
    std::vector<double> d{0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0};
    write("nrrd_attached", "double", "NRRD0004\ntype: double\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\n\n" + bytes_of(d));

    const std::string sep = "\n--sylva-fuzz-data--\n";
    write("nrrd_detached", "u8", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3 4\nencoding: raw\ndata file: v.raw\n" + sep + ramp(24, 1));
    write("nrrd_detached", "u16_lineskip",
          "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 2 2 3\nencoding: raw\nendian: little\nline skip: 1\ndata file: ./v.raw\n" + sep +
              "a line\n" + ramp(12, 2));
    write("nrrd_detached", "tail", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -1\ndata file: v.raw\n" +
                                       sep + "HEAD" + ramp(8, 1));
#if SYLVA_HAVE_ZLIB
    write("nrrd_detached", "gzip", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3 4\nencoding: gzip\ndata file: v.raw.gz\n" + sep +
                                       gzip(ramp(24, 1)));
    const std::string gz = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3 4\nencoding: gzip\n\n";
    write("nrrd_gzip", "stored_u8", std::string(1, '\0') + gz + gzip(ramp(24, 1)));
    const std::string gz16 = "NRRD0004\ntype: unsigned short\ndimension: 3\nsizes: 2 2 3\nencoding: gz\nendian: big\n\n";
    write("nrrd_gzip", "stored_u16", std::string(1, '\0') + gz16 + gzip(ramp(12, 2)));
    write("nrrd_gzip", "compressed_by_harness_u8", std::string(1, '\1') + gz + ramp(24, 1));
    write("nrrd_gzip", "compressed_by_harness_float",
          std::string(1, '\1') + "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\nendian: little\n\n" + bytes_of(f));
#endif

    write("tf_text", "ramp", "# density r g b a\n0 0 0 0 0\n0.5 1 0.5 0.2 0.1\n1 1 1 1 1\n");
    write("tf_text", "step", "0.2\t1 0 0 0\n0.2 1 0 0 0.9 # a step\n\n1e-3 0.1 0.2 0.3 0.4\n");
    write("tf_json", "points", "{\"points\": [[0, 0, 0, 0, 0], [0.5, 1, 0.5, 0.25, 0.5], [1, 1, 1, 1, 1]]}");
    write("tf_json", "entries", "{\"name\": \"ct\", \"points\": [[0.1, 0.6, 0.25, 0.15, 0.0], [1, 1, 1, 1, 0.95]],\n \"entries\": 300,"
                                " \"extra\": {\"a\": [1, 2, {\"b\": null}], \"c\": true, \"d\": \"x\\u0041\"}}");

    std::vector<float> pts;
    for (int i = 0; i < 15; ++i) pts.push_back(std::sin(float(i)) * 3.0f);
    write("particles", "named", "halo_5x3_float32.raw\n" + bytes_of(pts));
    write("particles", "unnamed", "points.raw\n" + bytes_of(pts));
    write("particles", "one", "p_1x3_float32.raw\n" + bytes_of(std::vector<float>{1.0f, 2.0f, 3.0f}));
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: fuzz_make_corpus OUTDIR\n";
        return 2;
    }
    out_root = argv[1];
    structures();
    readers();
    return 0;
}
