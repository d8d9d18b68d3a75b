// fuzz_replay TARGET DIR...: runs every file in each DIR through fuzz target TARGET's harness
// (fuzz/harness/*.hpp), compiled by the project's own compiler without libFuzzer. ctest runs it
// over the committed crash inputs (tests/fuzz_regressions/TARGET/) and the seed corpora
// (fuzz/corpus/TARGET/): a harness aborts on a broken promise, the sanitizer build reports
// memory errors and undefined behaviour, and a fixed crash that comes back fails the suite.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "harness/octree.hpp"
#include "harness/readers.hpp"
#include "harness/structures.hpp"
#if SYLVA_FUZZ_REPLAY_STORE
#include "harness/store.hpp"
#endif

namespace {

using Harness = int (*)(const std::uint8_t*, std::size_t);

const std::map<std::string, Harness>& harnesses() {
    static const std::map<std::string, Harness> all{
        {"raw_name", sylva_fuzz::fuzz_raw_name},
        {"raw", sylva_fuzz::fuzz_raw},
        {"nrrd_attached", sylva_fuzz::fuzz_nrrd_attached},
        {"nrrd_detached", sylva_fuzz::fuzz_nrrd_detached},
        {"nrrd_gzip", sylva_fuzz::fuzz_nrrd_gzip},
        {"tf_text", sylva_fuzz::fuzz_tf_text},
        {"tf_json", sylva_fuzz::fuzz_tf_json},
        {"particles", sylva_fuzz::fuzz_particles},
        {"bih", sylva_fuzz::fuzz_bih},
        {"lod", sylva_fuzz::fuzz_lod},
        {"kd", sylva_fuzz::fuzz_kd},
        {"ikd", sylva_fuzz::fuzz_ikd},
        {"octree", sylva_fuzz::fuzz_octree},
        {"octree_elements", sylva_fuzz::fuzz_octree_elements},
#if SYLVA_FUZZ_REPLAY_STORE
        {"store_brick", sylva_fuzz::fuzz_store_brick},
        {"store_build_info", sylva_fuzz::fuzz_store_build_info},
#endif
    };
    return all;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3 || !harnesses().count(argv[1])) {
        std::fprintf(stderr, "usage: fuzz_replay TARGET DIR... (TARGET: a fuzz target of fuzz/targets.cmake)\n");
        return 2;
    }
    Harness run = harnesses().at(argv[1]);
    std::size_t inputs = 0;
    for (int a = 2; a < argc; ++a) {
        std::error_code ec;
        if (!std::filesystem::is_directory(argv[a], ec)) continue;  // a target without regressions yet
        std::vector<std::filesystem::path> files;
        for (const auto& e : std::filesystem::directory_iterator(argv[a]))
            if (e.is_regular_file()) files.push_back(e.path());
        std::sort(files.begin(), files.end());
        for (const auto& f : files) {
            std::ifstream in(f, std::ios::binary);
            std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            std::printf("%s: %s (%zu bytes)\n", argv[1], f.string().c_str(), bytes.size());
            std::fflush(stdout);
            run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
            ++inputs;
        }
    }
    std::printf("%s: %zu inputs replayed, no finding\n", argv[1], inputs);
    return inputs > 0 ? 0 : 1;  // no input at all: a wrong path, not a pass
}
