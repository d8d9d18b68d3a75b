// Writes the volumes sylva-render's value-range tests read (issue 10) into the folder argv[1]
// (little-endian, as the readers expect):
//   ct12_48x48x40_uint16.raw     a 12-bit CT phantom stored in uint16, as scanners write it:
//                                air 0..40, soft tissue 850..1150, a bone shell up to 3926
//   ct12.nrrd                    the same voxels in NRRD, stating `min: 0` and `max: 4095`
//   signed_40x40x40_float32.raw  a float32 field in [-1, 1] (negative outside a ball)
//   large_40x40x40_float32.raw   a float32 field in [0, 1e6]
// None of them shows anything when normalised by the type's range (uint16: / 65535) with the
// default threshold 0.1 and CT transfer function; all do over the data's own range.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

/// Position of voxel (x, y, z) of an n-voxel axis in [-0.5, 0.5]^3 (voxel centres).
struct Point {
    float x, y, z, r;
};
Point at(int x, int y, int z, int nx, int ny, int nz) {
    Point p{(x + 0.5f) / nx - 0.5f, (y + 0.5f) / ny - 0.5f, (z + 0.5f) / nz - 0.5f, 0.0f};
    p.r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    return p;
}

std::uint16_t ct_value(const Point& p, std::uint32_t i) {
    float shell = std::fabs(p.r - 0.33f);  // bone: 3526..3926 across a shell 0.1 thick
    if (shell < 0.05f) return static_cast<std::uint16_t>(3926 - static_cast<int>(8000.0f * shell));
    if (p.r < 0.33f) return static_cast<std::uint16_t>(1000 + static_cast<int>(300.0f * p.x));
    return static_cast<std::uint16_t>((i * 2654435761u >> 16) % 41u);  // air: noise in 0..40
}

template <class T>
bool write(const std::filesystem::path& path, const std::string& header, const std::vector<T>& v) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << header;
    out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
    if (!out) std::fprintf(stderr, "make_test_volumes: cannot write %s\n", path.string().c_str());
    return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_test_volumes FOLDER\n");
        return 2;
    }
    std::filesystem::path dir(argv[1]);
    std::filesystem::create_directories(dir);
    std::vector<std::uint16_t> ct;
    for (int z = 0; z < 40; ++z)
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 48; ++x) ct.push_back(ct_value(at(x, y, z, 48, 48, 40), static_cast<std::uint32_t>(ct.size())));
    ct[ct.size() / 2 + 24] = 3926;  // the maximum, wherever the shell's rounding lands
    std::vector<float> signed_field, large_field;
    for (int z = 0; z < 40; ++z)
        for (int y = 0; y < 40; ++y)
            for (int x = 0; x < 40; ++x) {
                Point p = at(x, y, z, 40, 40, 40);
                signed_field.push_back(p.r < 0.45f ? std::cos(7.0f * p.r) : -1.0f);
                large_field.push_back(p.r < 0.45f ? 1e6f * std::exp(-12.0f * p.r * p.r) : 0.0f);
            }
    std::size_t centre = 20 + 40 * (20 + 40 * 20);  // exact extremes, so the tests know the data's range
    signed_field[centre] = 1.0f;
    large_field[centre] = 1e6f;
    const std::string nrrd = "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 48 48 40\nencoding: raw\nendian: little\n"
                             "min: 0\nmax: 4095\n\n";
    bool ok = write(dir / "ct12_48x48x40_uint16.raw", "", ct) && write(dir / "ct12.nrrd", nrrd, ct) &&
              write(dir / "signed_40x40x40_float32.raw", "", signed_field) &&
              write(dir / "large_40x40x40_float32.raw", "", large_field);
    return ok ? 0 : 1;
}
