// sylva-store's command line (see usage()).
#ifndef SYLVA_STORE_OPTIONS_HPP
#define SYLVA_STORE_OPTIONS_HPP

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <sylva/volume/value_range.hpp>

namespace sylva_store {

struct Options {
    std::string command;                 ///< build | info | verify
    std::string input;                   ///< build: FILE or procedural[:ml[:N|:XxYxZ]|:nbody]
    std::string store;                   ///< -o STORE (build) or the STORE argument
    std::uint32_t brick = 32;            ///< --brick 16|32 (also 4, 8 for tests)
    std::uint32_t border = 2;            ///< --border 1|2
    std::string codec = "zstd";          ///< --compress zstd|lz4|none
    std::string brick_format = "auto";   ///< --brick-format auto|float32|unorm16|unorm8
    int level = 1;                       ///< --level N (zstd 1..19, or -1..-5: its fast modes)
    std::uint64_t memory = std::uint64_t{1} << 30;  ///< --memory BYTES (K, M, G suffixes)
    bool resume = false;                 ///< --resume
    float resample = 1.0f;               ///< --resample K
    sylva::volume::ValueRange range;     ///< --range auto|type|LO,HI (files)
    std::optional<std::vector<float>> spacing;  ///< --spacing X,Y,Z
    std::uint32_t threads = 0;           ///< --threads T (0: all cores)
    bool quiet = false;                  ///< --quiet: no progress
    // For tests: small LMDB map (a "full disk") and small committed batches.
    std::uint64_t map_size = 0;          ///< --map-size BYTES
    std::uint64_t commit_bricks = 0;     ///< --commit-bricks N
};

/// The help text (CLI11's, every subcommand).
std::string usage();
/// Parses argv (CLI11); throws std::invalid_argument with a message for bad usage ("help" for -h).
Options parse(int argc, char** argv);
/// "256M" -> 268435456; K, M, G, T suffixes (powers of 1024), a plain number is bytes.
std::uint64_t parse_bytes(const std::string& opt, const std::string& v);

}  // namespace sylva_store

#endif
