// sylva-store: builds, describes and verifies out-of-core brick stores (sylva/store/): the
// bricked octree of a volume of any size, streamed from a file or a procedural source in
// bounded memory, in an LMDB directory that sylva-render --volume STORE reads progressively.
#include "options.hpp"

#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include <sylva/store/store.hpp>
#include <sylva/store/stream_build.hpp>
#include <sylva/volume/nrrd.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>

using namespace sylva;

namespace sylva_store {
namespace {

/// "procedural:ml:N" / "procedural:ml:XxYxZ" / "procedural:ml" (128^3) extents.
volume::Dims ml_dims(const std::string& spec) {
    const std::string prefix = "procedural:ml";
    if (spec == prefix) return volume::Dims(128u);
    std::string rest = spec.substr(prefix.size() + 1);
    volume::Dims d(0u);
    std::stringstream ss(rest);
    std::string part;
    int axis = 0;
    while (std::getline(ss, part, 'x')) {
        if (axis == 3 || part.empty() || part.find_first_not_of("0123456789") != std::string::npos || part.size() > 9)
            throw Error("input " + spec + ": expected procedural:ml:N or procedural:ml:XxYxZ");
        d[axis++] = static_cast<std::uint32_t>(std::stoul(part));
    }
    if (axis == 1) d = volume::Dims(d.x);
    else if (axis != 3) throw Error("input " + spec + ": expected procedural:ml:N or procedural:ml:XxYxZ");
    return d;
}

std::optional<vec3> spacing_of(const Options& o) {
    if (!o.spacing) return std::nullopt;
    return vec3((*o.spacing)[0], (*o.spacing)[1], (*o.spacing)[2]);
}

/// The slice source of INPUT (and --resample).
std::unique_ptr<store::SliceSource> open_input(const Options& o) {
    std::unique_ptr<store::SliceSource> src;
    const std::string& in = o.input;
    if (in == "procedural:ml" || in.rfind("procedural:ml:", 0) == 0) {
        volume::MarschnerLobbConfig c;
        if (o.spacing) c.spacing = *spacing_of(o);
        src = std::make_unique<store::MarschnerLobbSlices>(ml_dims(in), c);
    } else if (in == "procedural" || in == "procedural:nbody") {
        volume::SparseNbodyConfig c;
        if (o.spacing) c.spacing = *spacing_of(o);
        src = std::make_unique<store::GridSlices>(volume::sparse_nbody(volume::Dims(192u), 7u, c));
    } else if (in.rfind("procedural", 0) == 0) {
        throw Error("input " + in + ": unknown procedural volume (procedural:ml[:N|:XxYxZ] or procedural:nbody)");
    } else {
        std::filesystem::path p(in);
        std::string ext = p.extension().string();
        for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (ext == ".raw") {
            volume::RawInfo info = volume::parse_raw_name(p.filename().string());
            if (o.spacing) info.spacing = *spacing_of(o);
            src = std::make_unique<store::RawFileSlices>(p, info, o.range);
        } else {
            volume::Volume v = volume::read_volume(p, spacing_of(o), o.range);  // NRRD: read whole
            std::string type = volume::scalar_name(v.type), range = volume::range_source_name(v.range_source);
            float lo = v.range_lo, hi = v.range_hi;
            volume::DensityGrid g = volume::normalize(v);
            src = std::make_unique<store::GridSlices>(std::move(g), type, lo, hi, range);
        }
    }
    if (o.resample != 1.0f) src = std::make_unique<store::ResampledSlices>(std::move(src), o.resample);
    return src;
}

/// INPUT plus the options that change the volume: what --resume compares.
std::string input_name(const Options& o) {
    std::string s = o.input;
    if (o.resample != 1.0f) s += " --resample " + std::to_string(o.resample);
    if (o.range.mode != volume::ValueRange::Mode::Auto) s += " --range " + o.range.text();
    if (o.spacing) s += " --spacing " + std::to_string((*o.spacing)[0]) + "," + std::to_string((*o.spacing)[1]) + "," +
                        std::to_string((*o.spacing)[2]);
    return s;
}

std::string clock_text(double s) {
    if (!(s >= 0.0) || s > 1e7) return "--:--";
    auto t = static_cast<long>(s + 0.5);
    char buf[32];
    if (t >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
    else std::snprintf(buf, sizeof buf, "%ld:%02ld", t / 60, t % 60);
    return buf;
}

/// The progress line: a redrawn bar on a terminal, a plain line every 5 s otherwise.
class Progress {
public:
    explicit Progress(bool quiet) : quiet_(quiet), tty_(::isatty(2) == 1) {}
    void operator()(const store::StreamProgress& p) {
        if (quiet_) return;
        const bool last = p.bricks_done == p.bricks_total;
        const double since = p.seconds - last_;
        if (!last && since < (tty_ ? 0.2 : 5.0)) return;
        last_ = p.seconds;
        const double f = p.bricks_total ? double(p.bricks_done) / double(p.bricks_total) : 1.0;
        const double rate = p.seconds > 0.0 ? double(p.bricks_done) / p.seconds : 0.0;
        const double mbs = p.seconds > 0.0 ? double(p.source_bytes) / p.seconds / 1e6 : 0.0;
        const double left = f > 0.0 ? p.seconds * (1.0 - f) / f : -1.0;
        char line[256];
        std::string bar(24, '.');
        for (int i = 0; i < int(f * 24.0 + 0.5) && i < 24; ++i) bar[std::size_t(i)] = '#';
        std::snprintf(line, sizeof line, "building [%s] %3d%% %" PRIu64 "/%" PRIu64 " bricks, %.0f bricks/s, %.1f MB/s of voxels, %s elapsed, %s left",
                      bar.c_str(), int(f * 100.0), p.bricks_done, p.bricks_total, rate, mbs, clock_text(p.seconds).c_str(),
                      clock_text(left).c_str());
        if (tty_) std::fprintf(stderr, "\r%s\033[K%s", line, last ? "\n" : "");
        else std::fprintf(stderr, "%s\n", line);
        std::fflush(stderr);
    }

private:
    bool quiet_, tty_;
    double last_ = -1e9;
};

int build(const Options& o) {
    auto src = open_input(o);
    store::StreamConfig cfg;
    cfg.octree = {o.brick, o.border};
    cfg.octree.format = store::brick_format_for(o.brick_format, src->voxel_type());
    cfg.codec = store::codec_from_name(o.codec);
    cfg.level = o.level;
    cfg.memory_bytes = o.memory;
    cfg.resume = o.resume;
    if (o.map_size) cfg.writer.map_bytes = o.map_size;
    if (o.commit_bricks) cfg.writer.batch_bricks = o.commit_bricks, cfg.batch_bricks = std::uint32_t(std::min<std::uint64_t>(o.commit_bricks, 64));
    const std::string name = input_name(o);
    store::BuildInfo plan = store::plan_info(*src, name, cfg);
    const double raw = double(plan.node_count) * plan.brick_words() * 4.0;
    std::filesystem::path parent = std::filesystem::absolute(o.store).parent_path();
    const std::uint64_t free = store::free_bytes(parent);
    if (!o.quiet)
        std::fprintf(stderr, "sylva-store: %s: %ux%ux%u voxels, %u levels, %u bricks of %u^3 (+%u border), %s of bricks "
                             "before compression, %s free on disk\n",
                     name.c_str(), plan.dims.x, plan.dims.y, plan.dims.z, plan.levels, plan.node_count, plan.brick_size,
                     plan.border, store::bytes_text(raw).c_str(), store::bytes_text(double(free)).c_str());
    if (cfg.codec == store::Codec::none && free > 0 && double(free) < raw * 1.05)
        throw store::DiskFullError("store " + o.store + ": needs about " + store::bytes_text(raw * 1.05) + ", only " +
                                   store::bytes_text(double(free)) + " free; nothing written");
    Progress progress(o.quiet);
    cfg.progress = [&progress](const store::StreamProgress& p) { progress(p); };
    ThreadPool pool(o.threads);
    store::StreamResult r = store::build_store(*src, name, o.store, cfg, pool);
    if (!o.quiet)
        std::fprintf(stderr, "sylva-store: %s complete: %" PRIu64 " bricks written%s, %s stored (%.2fx smaller), %.1f s, "
                             "%.1f MB/s of voxels, planned memory %s\n",
                     o.store.c_str(), r.bricks_written,
                     r.bricks_skipped ? (" (" + std::to_string(r.bricks_skipped) + " were already stored)").c_str() : "",
                     store::bytes_text(double(r.brick_bytes_stored)).c_str(),
                     r.brick_bytes_stored ? double(r.brick_bytes_raw) / double(r.brick_bytes_stored) : 0.0, r.seconds,
                     double(r.source_bytes) / r.seconds / 1e6, store::bytes_text(double(r.planned_memory)).c_str());
    return 0;
}

int info(const Options& o) {
    store::Store s = store::Store::open(o.store, true);
    const store::BuildInfo& b = s.build_info();
    std::uint64_t stored = s.stored_brick_bytes();
    double raw = double(s.bricks_stored()) * b.brick_words() * 4.0;
    std::printf("store: %s\nformat_version: %u\ncomplete: %s\n", o.store.c_str(), s.format_version(),
                s.complete() ? "yes" : "no (an interrupted build: finish it with build ... --resume)");
    std::printf("%s", store::to_text(b).c_str());
    std::printf("bricks_stored: %" PRIu64 " of %u\nbrick_words: %u\nindex_words: %zu\n", s.bricks_stored(), b.node_count,
                b.brick_words(), s.index().size());
    std::printf("brick_bytes_raw: %.0f\nbrick_bytes_stored: %" PRIu64 "\ncompression_ratio: %.3f\nfile_bytes: %" PRIu64 "\n",
                raw, stored, stored ? raw / double(stored) : 0.0, s.file_bytes());
    std::printf("content_digest: %016" PRIx64 "\n", s.content_digest());
    return 0;
}

int verify(const Options& o) {
    store::Store s = store::Store::open(o.store, true);
    const bool tty = ::isatty(2) == 1;
    auto t0 = std::chrono::steady_clock::now();
    store::VerifyReport r = s.verify([&](std::uint64_t done, std::uint64_t total) {
        double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (tty && sec > 1.0) std::fprintf(stderr, "\rverifying %" PRIu64 "/%" PRIu64 " bricks\033[K", done, total);
    });
    if (tty && std::chrono::steady_clock::now() - t0 > std::chrono::seconds(1)) std::fprintf(stderr, "\n");
    std::printf("store: %s\nbricks checked: %" PRIu64 " of %" PRIu64 "\n", o.store.c_str(), r.bricks_checked, r.bricks_expected);
    if (!r.complete)
        std::printf("INCOMPLETE: %" PRIu64 " bricks missing and no index (an interrupted build: finish it with the same "
                    "build command and --resume)\n",
                    r.missing);
    else if (r.missing) std::printf("MISSING: %" PRIu64 " bricks\n", r.missing);
    if (!r.corrupt.empty()) {
        std::printf("CORRUPT: %zu bricks fail their checksum or do not decode; keys:", r.corrupt.size());
        for (std::uint32_t k : r.corrupt) std::printf(" %u", k);
        std::printf("\n");
    }
    if (!r.unexpected.empty()) std::printf("UNEXPECTED: %zu keys outside the octree\n", r.unexpected.size());
    std::printf("%s\n", r.ok() ? "OK: every brick matches its checksum" : "FAILED");
    return r.ok() ? 0 : 1;
}

}  // namespace
}  // namespace sylva_store

int main(int argc, char** argv) {
    using namespace sylva_store;
    Options o;
    try {
        o = parse(argc, argv);
    } catch (const std::invalid_argument& e) {
        if (std::string(e.what()) == "help") {
            std::cout << usage();
            return 0;
        }
        std::cerr << "sylva-store: " << e.what() << "\nRun sylva-store --help for the commands and options.\n";
        return 2;
    }
    try {
        if (o.command == "build") return build(o);
        if (o.command == "info") return info(o);
        return verify(o);
    } catch (const store::DiskFullError& e) {
        std::cerr << "\nsylva-store: " << e.what() << "\n";
        return 3;
    } catch (const std::exception& e) {
        std::cerr << "\nsylva-store: " << e.what() << "\n";
        return 1;
    }
}
