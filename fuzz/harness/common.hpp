// fuzz/harness/common.hpp -- what every fuzz harness shares (issue 16): the input as a file in a
// per-process temporary folder (readers take paths), the input as 32-bit words (encodings), a
// handful of rays over a box, and the check that turns a broken promise into a crash.
//
// The harnesses (fuzz/harness/*.hpp) are plain functions `int fuzz_NAME(const uint8_t*, size_t)`:
// fuzz/NAME.cpp hands them to libFuzzer, and tests/fuzz_regressions replays the committed
// crash inputs and seed corpora through the same functions in the ordinary (g++) test suite.
#ifndef SYLVA_FUZZ_HARNESS_COMMON_HPP
#define SYLVA_FUZZ_HARNESS_COMMON_HPP

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include <unistd.h>

#include <sylva/core/math.hpp>
#include <sylva/core/ray.hpp>

namespace sylva_fuzz {

using sylva::vec3;

/// A broken promise of the library (not bad input: that must throw sylva::Error): print and
/// abort, so libFuzzer records the input as a crash.
#define SYLVA_FUZZ_CHECK(cond, what)                                                                         \
    do {                                                                                                    \
        if (!(cond)) {                                                                                      \
            std::fprintf(stderr, "sylva fuzz check failed at %s:%d: %s (%s)\n", __FILE__, __LINE__, #cond, what); \
            std::abort();                                                                                   \
        }                                                                                                   \
    } while (0)

/// The process's own scratch folder, in /dev/shm when there is one (no disk writes per run),
/// removed at exit.
class ScratchDir {
public:
    static const std::filesystem::path& path() {
        static ScratchDir dir;
        return dir.path_;
    }

private:
    ScratchDir() {
        std::error_code ec;
        std::filesystem::path base =
            std::filesystem::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0
                ? std::filesystem::path("/dev/shm")
                : std::filesystem::temp_directory_path();
        path_ = base / ("sylva-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(path_);
    }
    ~ScratchDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    std::filesystem::path path_;
};

/// A file name made of `s`: no folder separators or NULs, not "." or "..", at most 200 bytes.
inline std::string safe_name(std::string_view s) {
    std::string out(s.substr(0, 200));
    for (char& c : out)
        if (c == '/' || c == '\0') c = '_';
    if (out.empty() || out == "." || out == "..") out = "x" + out;
    return out;
}

/// A file in the scratch folder, removed when this goes out of scope (a harness run leaves
/// nothing behind, whatever names the inputs choose).
class ScratchFile {
public:
    /// Writes `bytes` to NAME in the scratch folder (replacing it).
    ScratchFile(const std::string& name, const void* bytes, std::size_t size) : path_(ScratchDir::path() / name) {
        std::ofstream out(path_, std::ios::binary | std::ios::trunc);
        out.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(size));
        SYLVA_FUZZ_CHECK(out.good(), "cannot write the input to the scratch folder");
    }
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;
    ~ScratchFile() {
        std::error_code ec;
        std::filesystem::remove(path_, ec);
    }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

/// The input split at its first newline: {first line, the rest}. No newline: {all, nothing}.
struct Split {
    std::string_view head;
    std::string_view rest;
};
inline Split split_line(const std::uint8_t* data, std::size_t size) {
    std::string_view all(reinterpret_cast<const char*>(data), size);
    std::size_t nl = all.find('\n');
    if (nl == std::string_view::npos) return {all, {}};
    return {all.substr(0, nl), all.substr(nl + 1)};
}

/// The input as little-endian 32-bit words, in a buffer of exactly that many words (so the
/// address sanitizer sees any read past the end); trailing bytes are dropped.
inline std::vector<std::uint32_t> words_of(const std::uint8_t* data, std::size_t size) {
    std::vector<std::uint32_t> w(size / 4);
    if (!w.empty()) std::memcpy(w.data(), data, w.size() * 4);
    return w;
}

/// A handful of rays over the box [lo, hi] (a unit box when it is not finite and ordered):
/// diagonals from outside, from the centre, axis-parallel through the centre and along the
/// faces and edges (the iterators' parallel-ray paths), a backwards ray and a grazing one.
inline std::vector<sylva::Ray> rays_over(vec3 lo, vec3 hi) {
    bool ok = std::isfinite(lo.x) && std::isfinite(lo.y) && std::isfinite(lo.z) && std::isfinite(hi.x) &&
              std::isfinite(hi.y) && std::isfinite(hi.z) && lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z &&
              std::isfinite(hi.x - lo.x) && std::isfinite(hi.y - lo.y) && std::isfinite(hi.z - lo.z);
    if (!ok) lo = vec3(0.0f), hi = vec3(1.0f);
    vec3 c = 0.5f * lo + 0.5f * hi, e = hi - lo;
    vec3 out = lo - 0.5f * e - vec3(1.0f);
    return {
        {out, glm::normalize(c - out + vec3(1e-3f, 2e-3f, 3e-3f))},  // diagonal, from outside
        {c, vec3(-0.37f, 0.81f, -0.45f)},                            // from the centre
        {vec3(lo.x - 1.0f, c.y, c.z), vec3(1.0f, 0.0f, 0.0f)},       // axis-parallel through the centre
        {vec3(c.x, hi.y + 1.0f, c.z), vec3(0.0f, -1.0f, 0.0f)},
        {vec3(c.x, c.y, lo.z - 1.0f), vec3(0.0f, 0.0f, 1.0f)},
        {vec3(lo.x, lo.y - 1.0f, c.z), vec3(0.0f, 1.0f, 0.0f)},      // in a face plane
        {vec3(lo.x, hi.y, lo.z - 1.0f), vec3(0.0f, 0.0f, 1.0f)},     // along an edge
        {hi + vec3(1.0f), vec3(-0.5f, -0.6f, -0.62f)},               // backwards, through a corner region
    };
}

}  // namespace sylva_fuzz

#endif  // SYLVA_FUZZ_HARNESS_COMMON_HPP
