// sylva-store-bench: the out-of-core brick store (issue 13), measured.
//   codecs    per codec and level: encode and decode rate (bricks/s, MB/s of brick bytes, one
//             thread) and stored size, over every brick of a case's octree (B 32, border 2)
//   backends  the same zstd-1 bricks written into LMDB (sylva's store: batched commits) and into
//             an HDF5 chunked dataset (one chunk per brick, written and read as raw chunks, so
//             both hold the same bytes), then read back cold (pages dropped with
//             posix_fadvise) and warm: bricks/s
//   build     the streamed builder (sylva-store build) per codec: MB/s of source voxels,
//             bricks/s, against a dd-like sequential write (write + fdatasync) of the same byte
//             count in the same run; then Store::read_brick over every brick, cold and warm
// Cases: aneurism (../shared/data), aneurismxK (upsampled by K, float32 slices), ml256, ml512 (procedural Marschner-Lobb, float32, generated
// slice by slice), ml1024u16 (Marschner-Lobb quantised to uint16: the 2 GiB volume);
// NAME-file: NAME's voxels written once to a raw file (untimed) and built from it, cold.
// Medians of --runs runs. JSON records {case, impl, metric, value, unit} through bench::Report.
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <string_view>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/store/store.hpp>
#include <sylva/store/stream_build.hpp>
#include <sylva/store/write_tree.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>

#if SYLVA_STORE_BENCH_HDF5
#include <hdf5.h>
#endif

#include "bench.hpp"
#include "cli.hpp"

using namespace sylva;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// User + system CPU seconds of this process so far.
double cpu_seconds() {
    rusage u{};
    ::getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

/// Drops a file's pages from the page cache (clean pages only: call after fdatasync).
void drop_cache(const std::filesystem::path& p) {
    int fd = ::open(p.c_str(), O_RDONLY);
    if (fd < 0) return;
    ::fdatasync(fd);
    ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
    ::close(fd);
}

/// Seconds to write `bytes` sequentially in 8 MiB blocks and fdatasync them (what dd
/// conv=fdatasync does), in `dir`.
double dd_seconds(const std::filesystem::path& dir, std::uint64_t bytes) {
    auto p = dir / "dd.bin";
    std::vector<char> block(8u << 20, 'x');
    auto t0 = Clock::now();
    int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) throw Error("dd: cannot create " + p.string());
    for (std::uint64_t done = 0; done < bytes;) {
        std::size_t n = std::size_t(std::min<std::uint64_t>(block.size(), bytes - done));
        if (::write(fd, block.data(), n) != ssize_t(n)) throw Error("dd: write failed");
        done += n;
    }
    ::fdatasync(fd);
    ::close(fd);
    double s = seconds_since(t0);
    std::filesystem::remove(p);
    return s;
}

struct Options {
    std::vector<std::string> cases{"aneurism", "ml512"};
    int runs = 3;
    std::string json;
    std::filesystem::path dir = "store-bench-tmp";
    std::vector<std::string> sections{"codecs", "backends", "build"};
    std::vector<std::string> build_codecs{"zstd-1", "zstd-fast3", "lz4"};
    std::string brick_format = "auto";  ///< build section: sylva-store build's --brick-format
    unsigned threads = 0;
};

/// A case: a slice source (streamed) and, for codecs/backends, its in-core tree when it fits.
struct Case {
    std::string name;
    std::function<std::unique_ptr<store::SliceSource>()> source;
    std::uint64_t voxel_bytes = 0;
};

/// Marschner-Lobb quantised to uint16 (round(d * 65535)), normalised over the type's range: a
/// 16-bit volume like the paper's CT data, generated slice by slice.
class MlU16Slices final : public store::SliceSource {
public:
    explicit MlU16Slices(volume::Dims d) : ml_(d) {}
    [[nodiscard]] volume::Dims dims() const override { return ml_.dims(); }
    [[nodiscard]] vec3 spacing() const override { return ml_.spacing(); }
    void read(std::uint32_t z, std::span<float> out) override { quantise(z, out, nullptr); }
    void read(std::uint32_t z, std::span<float> out, ThreadPool& pool) override { quantise(z, out, &pool); }
    [[nodiscard]] std::string voxel_type() const override { return "uint16"; }
    [[nodiscard]] float range_hi() const override { return 65535.0f; }
    [[nodiscard]] std::string range_source() const override { return "type range"; }
    [[nodiscard]] std::uint64_t slice_source_bytes() const override { return std::uint64_t(dims().x) * dims().y * 2u; }

private:
    void quantise(std::uint32_t z, std::span<float> out, ThreadPool* pool) {
        if (pool) ml_.read(z, out, *pool);
        else ml_.read(z, out);
        for (float& v : out) v = std::round(v * 65535.0f) * (1.0f / 65535.0f);  // the uint16 value, normalised
    }
    store::MarschnerLobbSlices ml_;
};

/// Writes every slice of `src` to `path` as raw uint16 (round(d * 65535)) or float32 samples: the
/// file a `-file` case builds from. Untimed: it stands for a volume already on disk.
void write_raw(store::SliceSource& src, const std::filesystem::path& path, bool u16) {
    const volume::Dims d = src.dims();
    std::vector<float> slice(std::size_t{d.x} * d.y);
    std::vector<std::uint16_t> q(u16 ? slice.size() : 0);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) throw Error("cannot create " + path.string());
    for (std::uint32_t z = 0; z < d.z; ++z) {
        src.read(z, slice);
        bool ok;
        if (u16) {
            for (std::size_t i = 0; i < slice.size(); ++i) q[i] = std::uint16_t(std::lround(slice[i] * 65535.0f));
            ok = std::fwrite(q.data(), 2, q.size(), f) == q.size();
        } else {
            ok = std::fwrite(slice.data(), 4, slice.size(), f) == slice.size();
        }
        if (!ok) {
            std::fclose(f);
            throw Error("cannot write " + path.string() + " (disk full?)");
        }
    }
    if (std::fclose(f) != 0) throw Error("cannot write " + path.string());
}

Case make_case(const std::string& name, const std::filesystem::path& dir);

/// NAME-file: the volume of case NAME written once to a raw file in `dir` (untimed), and built
/// from that file as `sylva-store build FILE` reads it (type range for uint16): the build
/// without the cost of generating or resampling its voxels. The file's pages are dropped from
/// the page cache before each build, so the build reads the disk.
Case make_file_case(const std::string& name, const std::filesystem::path& dir) {
    const std::string base = name.substr(0, name.size() - 5);
    Case inner = make_case(base, dir);
    auto src = inner.source();
    const bool u16 = src->voxel_type() == "uint16";
    const volume::Dims d = src->dims();
    const std::string file_name = base + "_" + std::to_string(d.x) + "x" + std::to_string(d.y) + "x" +
                                  std::to_string(d.z) + (u16 ? "_uint16.raw" : "_float32.raw");
    std::filesystem::create_directories(dir);
    const std::filesystem::path file = dir / file_name;
    write_raw(*src, file, u16);
    Case c;
    c.name = name;
    c.voxel_bytes = inner.voxel_bytes;
    c.source = [file, u16]() -> std::unique_ptr<store::SliceSource> {
        drop_cache(file);
        return std::make_unique<store::RawFileSlices>(file, volume::parse_raw_name(file.filename().string()),
                                                      u16 ? volume::ValueRange::of_type() : volume::ValueRange{});
    };
    return c;
}

Case make_case(const std::string& name, const std::filesystem::path& dir) {
    if (name.size() > 5 && name.substr(name.size() - 5) == "-file") return make_file_case(name, dir);
    Case c;
    c.name = name;
    if (name == "aneurism" || name.rfind("aneurismx", 0) == 0) {
        auto file = std::filesystem::path(SYLVA_STORE_BENCH_DATA) / "aneurism_256x256x256_uint8.raw";
        if (!std::filesystem::exists(file)) throw Error("aneurism: " + file.string() + " is missing");
        // aneurismxK: upsampled by K (sylva-store build ... --resample K), float32 slices
        const float k = name == "aneurism" ? 1.0f : std::stof(name.substr(9));
        c.source = [file, k]() -> std::unique_ptr<store::SliceSource> {
            auto raw = std::make_unique<store::RawFileSlices>(file, volume::parse_raw_name(file.filename().string()));
            if (k == 1.0f) return raw;
            return std::make_unique<store::ResampledSlices>(std::move(raw), k);
        };
        c.voxel_bytes = 256u * 256u * 256u;
    } else if (name.rfind("ml", 0) == 0) {
        bool u16 = name.size() > 3 && name.substr(name.size() - 3) == "u16";
        std::uint32_t n = std::uint32_t(std::stoul(name.substr(2, name.size() - 2 - (u16 ? 3 : 0))));
        if (u16) c.source = [n] { return std::make_unique<MlU16Slices>(volume::Dims(n)); };
        else c.source = [n] { return std::make_unique<store::MarschnerLobbSlices>(volume::Dims(n)); };
        c.voxel_bytes = std::uint64_t(n) * n * n * (u16 ? 2u : 4u);
    } else {
        throw Error("unknown case " + name + " (aneurism, mlN, mlNu16)");
    }
    return c;
}

/// Every brick of the case's octree (B 32, border 2), from a streamed build with no compression
/// read back (so cases larger than memory-for-a-pyramid work too), at most `limit` of them.
std::vector<std::vector<std::uint32_t>> case_bricks(const Case& c, const std::filesystem::path& dir, ThreadPool& pool,
                                                    std::size_t limit) {
    auto path = dir / (c.name + "-raw");
    std::filesystem::remove_all(path);
    auto src = c.source();
    store::StreamConfig cfg;
    cfg.codec = store::Codec::none;
    cfg.memory_bytes = std::uint64_t(8) << 30;
    store::build_store(*src, c.name, path, cfg, pool);
    store::Store s = store::Store::open(path);
    std::vector<std::vector<std::uint32_t>> bricks;
    std::size_t step = std::max<std::size_t>(1, s.brick_count() / limit);
    for (std::uint32_t k = 0; k < s.brick_count() && bricks.size() < limit; k += std::uint32_t(step)) {
        bricks.emplace_back(s.brick_words());
        if (s.read_brick(k, bricks.back()) != octree::BrickStatus::ok) throw Error("case_bricks: bad brick");
    }
    std::filesystem::remove_all(path);
    return bricks;
}

struct CodecSetting {
    store::Codec codec;
    int level;
    [[nodiscard]] std::string name() const {
        if (codec != store::Codec::zstd) return store::codec_name(codec);
        return level < 0 ? "zstd-fast" + std::to_string(-level) : "zstd-" + std::to_string(level);
    }
};

void codecs_section(const Case& c, const std::vector<std::vector<std::uint32_t>>& bricks, const Options& o,
                    bench::Report& report) {
    const double raw = double(bricks.size()) * bricks[0].size() * 4.0;
    for (CodecSetting cs : {CodecSetting{store::Codec::none, 0}, CodecSetting{store::Codec::lz4, 0},
                            CodecSetting{store::Codec::zstd, -3}, CodecSetting{store::Codec::zstd, -1},
                            CodecSetting{store::Codec::zstd, 1}, CodecSetting{store::Codec::zstd, 3},
                            CodecSetting{store::Codec::zstd, 9}}) {
        std::vector<std::vector<std::byte>> enc(bricks.size());
        std::vector<double> te, td;
        std::vector<std::uint32_t> out(bricks[0].size());
        for (int r = 0; r < o.runs; ++r) {
            auto t0 = Clock::now();
            for (std::size_t i = 0; i < bricks.size(); ++i) store::encode_brick(bricks[i], cs.codec, cs.level, enc[i]);
            te.push_back(seconds_since(t0));
            t0 = Clock::now();
            for (auto& e : enc)
                if (store::decode_brick(e, out) != store::DecodeStatus::ok) throw Error("decode failed");
            td.push_back(seconds_since(t0));
        }
        double stored = 0;
        for (auto& e : enc) stored += double(e.size());
        const std::string impl = cs.name();
        report.add(c.name, impl, "encode_bricks_per_s", double(bricks.size()) / median(te), "bricks/s");
        report.add(c.name, impl, "encode_MB_per_s", raw / median(te) / 1e6, "MB/s");
        report.add(c.name, impl, "decode_bricks_per_s", double(bricks.size()) / median(td), "bricks/s");
        report.add(c.name, impl, "decode_MB_per_s", raw / median(td) / 1e6, "MB/s");
        report.add(c.name, impl, "compression_ratio", raw / stored, "x");
        report.add(c.name, impl, "stored_bytes_per_brick", stored / double(bricks.size()), "bytes");
    }
}

/// Writes the encoded bricks into a fresh LMDB store; returns seconds (commits included).
double lmdb_write(const std::vector<std::vector<std::byte>>& enc, std::uint32_t words, const std::filesystem::path& p) {
    std::filesystem::remove_all(p);
    store::BuildInfo info;
    info.input = "bench";
    info.dims = volume::Dims(1u);
    info.node_count = std::uint32_t(enc.size());
    info.brick_size = 32;
    info.border = 2;
    (void)words;
    auto t0 = Clock::now();
    store::StoreWriter w = store::StoreWriter::create(p, info, false);
    for (std::size_t i = 0; i < enc.size(); ++i) w.put(std::uint32_t(i), enc[i]);
    w.commit();
    return seconds_since(t0);
}

/// Reads every brick of an LMDB store written by lmdb_write (raw values, then decoded).
double lmdb_read(const std::filesystem::path& p, std::size_t count, std::uint32_t words) {
    store::lmdb::Env env("bench");
    mdb_env_set_maxdbs(env.get(), 4);
    store::lmdb::check(mdb_env_open(env.get(), p.c_str(), MDB_RDONLY, 0644), "bench", "open");
    std::vector<std::uint32_t> out(words);
    auto t0 = Clock::now();
    store::lmdb::Txn txn(env, MDB_RDONLY);
    MDB_dbi dbi;
    store::lmdb::check(mdb_dbi_open(txn.get(), "bricks", MDB_INTEGERKEY, &dbi), "bench", "dbi");
    for (std::size_t i = 0; i < count; ++i) {
        unsigned k = unsigned(i);
        MDB_val key = store::lmdb::brick_key(k), v;
        if (mdb_get(txn.get(), dbi, &key, &v) != MDB_SUCCESS) throw Error("lmdb_read: missing");
        if (store::decode_brick(store::lmdb::bytes(v), out) != store::DecodeStatus::ok) throw Error("lmdb_read: bad");
    }
    return seconds_since(t0);
}

#if SYLVA_STORE_BENCH_HDF5
/// The encoded bricks as raw chunks of a chunked HDF5 dataset [count, words] of uint32 (one chunk
/// per brick; the deflate filter is declared so that chunks may have any size, and the chunks are
/// written and read directly with H5Dwrite_chunk / H5Dread_chunk: HDF5 stores the same bytes LMDB
/// does). Returns seconds including H5Fclose and fdatasync.
double hdf5_write(const std::vector<std::vector<std::byte>>& enc, std::uint32_t words, const std::filesystem::path& p) {
    std::filesystem::remove(p);
    auto t0 = Clock::now();
    hid_t f = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    hsize_t dims[2] = {enc.size(), words}, chunk[2] = {1, words};
    hid_t space = H5Screate_simple(2, dims, nullptr);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 2, chunk);
    H5Pset_deflate(dcpl, 1);
    hid_t ds = H5Dcreate2(f, "bricks", H5T_NATIVE_UINT32, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    for (std::size_t i = 0; i < enc.size(); ++i) {
        hsize_t off[2] = {i, 0};
        if (H5Dwrite_chunk(ds, H5P_DEFAULT, 0, off, enc[i].size(), enc[i].data()) < 0) throw Error("H5Dwrite_chunk");
    }
    H5Dclose(ds);
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(f);
    int fd = ::open(p.c_str(), O_RDONLY);
    ::fdatasync(fd);
    ::close(fd);
    return seconds_since(t0);
}

double hdf5_read(const std::filesystem::path& p, std::size_t count, std::uint32_t words) {
    std::vector<std::uint32_t> out(words);
    std::vector<std::byte> buf;
    auto t0 = Clock::now();
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t ds = H5Dopen2(f, "bricks", H5P_DEFAULT);
    for (std::size_t i = 0; i < count; ++i) {
        hsize_t off[2] = {i, 0};
        hsize_t size = 0;
        H5Dget_chunk_storage_size(ds, off, &size);
        buf.resize(size);
        std::uint32_t mask = 0;
        if (H5Dread_chunk(ds, H5P_DEFAULT, off, &mask, buf.data()) < 0) throw Error("H5Dread_chunk");
        if (store::decode_brick(buf, out) != store::DecodeStatus::ok) throw Error("hdf5_read: bad");
    }
    H5Dclose(ds);
    H5Fclose(f);
    return seconds_since(t0);
}
#endif

void backends_section(const Case& c, const std::vector<std::vector<std::uint32_t>>& bricks, const Options& o,
                      bench::Report& report) {
    std::vector<std::vector<std::byte>> enc(bricks.size());
    for (std::size_t i = 0; i < bricks.size(); ++i) store::encode_brick(bricks[i], store::Codec::zstd, 1, enc[i]);
    const std::uint32_t words = std::uint32_t(bricks[0].size());
    struct Backend {
        std::string name;
        std::function<double(const std::filesystem::path&)> write;
        std::function<double(const std::filesystem::path&)> read;
        std::filesystem::path path, data;
    };
    std::vector<Backend> backends;
    auto lp = o.dir / (c.name + "-lmdb");
    backends.push_back({"lmdb", [&](const std::filesystem::path& p) { return lmdb_write(enc, words, p); },
                        [&](const std::filesystem::path& p) { return lmdb_read(p, enc.size(), words); }, lp, lp / "data.mdb"});
#if SYLVA_STORE_BENCH_HDF5
    auto hp = o.dir / (c.name + ".h5");
    backends.push_back({"hdf5-chunked", [&](const std::filesystem::path& p) { return hdf5_write(enc, words, p); },
                        [&](const std::filesystem::path& p) { return hdf5_read(p, enc.size(), words); }, hp, hp});
#endif
    for (Backend& b : backends) {
        std::vector<double> tw, tc, tw2;
        for (int r = 0; r < o.runs; ++r) {
            tw.push_back(b.write(b.path));
            drop_cache(b.data);
            tc.push_back(b.read(b.path));
            tw2.push_back(b.read(b.path));
        }
        const double n = double(enc.size());
        report.add(c.name, b.name, "write_bricks_per_s", n / median(tw), "bricks/s");
        report.add(c.name, b.name, "read_cold_bricks_per_s", n / median(tc), "bricks/s");
        report.add(c.name, b.name, "read_warm_bricks_per_s", n / median(tw2), "bricks/s");
        report.add(c.name, b.name, "file_bytes", double(std::filesystem::file_size(b.data)), "bytes");
        std::filesystem::remove_all(b.path);
    }
}

void build_section(const Case& c, const Options& o, ThreadPool& pool, bench::Report& report) {
    for (CodecSetting cs : {CodecSetting{store::Codec::zstd, 1}, CodecSetting{store::Codec::zstd, -3},
                            CodecSetting{store::Codec::lz4, 0}}) {
        if (std::find(o.build_codecs.begin(), o.build_codecs.end(), cs.name()) == o.build_codecs.end()) continue;
        std::vector<double> tb, tcpu, tdd, tdd_stored, tcold, twarm;
        store::StreamResult last;
        std::uint64_t file_bytes = 0;
        for (int r = 0; r < o.runs; ++r) {
            auto path = o.dir / (c.name + "-" + cs.name());
            std::filesystem::remove_all(path);
            auto src = c.source();
            store::StreamConfig cfg;
            cfg.codec = cs.codec;
            cfg.level = cs.level;
            cfg.octree.format = store::brick_format_for(o.brick_format, src->voxel_type());
            cfg.memory_bytes = std::uint64_t(2) << 30;
            auto t0 = Clock::now();
            double c0 = cpu_seconds();
            last = store::build_store(*src, c.name, path, cfg, pool);
            tb.push_back(seconds_since(t0));
            tcpu.push_back(cpu_seconds() - c0);
            file_bytes = std::filesystem::file_size(path / "data.mdb");
            tdd.push_back(dd_seconds(o.dir, last.source_bytes));
            tdd_stored.push_back(dd_seconds(o.dir, file_bytes));
            store::Store s = store::Store::open(path);
            std::vector<std::uint32_t> out(s.brick_words());
            for (int pass = 0; pass < 2; ++pass) {
                if (pass == 0) drop_cache(path / "data.mdb");
                t0 = Clock::now();
                for (std::uint32_t k = 0; k < s.brick_count(); ++k)
                    if (s.read_brick(k, out) != octree::BrickStatus::ok) throw Error("build: bad brick");
                (pass == 0 ? tcold : twarm).push_back(seconds_since(t0));
            }
            std::filesystem::remove_all(path);
        }
        const std::string impl = "build-" + cs.name() + "-" + store::brick_format_name(last.info.brick_format);
        const double n = double(last.info.node_count), mb = double(last.source_bytes) / 1e6;
        report.add(c.name, impl, "build_s", median(tb), "s");
        report.add(c.name, impl, "build_MB_per_s_voxels", mb / median(tb), "MB/s");
        // CPU seconds of the build (all threads): on a machine whose pool.concurrency() cores are
        // free, a CPU-bound build takes about cpu / cores (the rows above are wall clock).
        report.add(c.name, impl, "build_cpu_s", median(tcpu), "s");
        report.add(c.name, impl, "build_cpu_s_per_core", median(tcpu) / double(pool.concurrency()), "s");
        report.add(c.name, impl, "build_bricks_per_s", n / median(tb), "bricks/s");
        report.add(c.name, impl, "dd_MB_per_s_same_bytes", mb / median(tdd), "MB/s");
        report.add(c.name, impl, "build_vs_dd_voxel_bytes", median(tdd) / median(tb), "x");
        report.add(c.name, impl, "dd_s_store_bytes", median(tdd_stored), "s");
        report.add(c.name, impl, "store_file_bytes", double(file_bytes), "bytes");
        report.add(c.name, impl, "compression_ratio", double(last.brick_bytes_raw) / double(last.brick_bytes_stored), "x");
        report.add(c.name, impl, "planned_memory_bytes", double(last.planned_memory), "bytes");
        report.add(c.name, impl, "read_cold_bricks_per_s", n / median(tcold), "bricks/s");
        report.add(c.name, impl, "read_warm_bricks_per_s", n / median(twarm), "bricks/s");
    }
}

/// Whether `v` names a case: aneurism, aneurismxK (K a decimal, e.g. 4 or 1.5), mlN or mlNu16
/// (written out rather than with std::regex, whose libstdc++ internals trip GCC 12's
/// -Wmaybe-uninitialized in the sanitizer build).
inline bool known_case(const std::string& v) {
    auto digits = [](std::string_view s) {
        return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    std::string_view s(v);
    if (s.size() > 5 && s.substr(s.size() - 5) == "-file") s.remove_suffix(5);  // NAME-file: NAME read from a raw file
    if (s == "aneurism") return true;
    if (s.rfind("aneurismx", 0) == 0) {
        std::string_view k = s.substr(9);
        std::size_t dot = k.find('.');
        return dot == std::string_view::npos ? digits(k) : digits(k.substr(0, dot)) && digits(k.substr(dot + 1));
    }
    if (s.rfind("ml", 0) == 0) {
        std::string_view n = s.substr(2);
        if (n.size() > 3 && n.substr(n.size() - 3) == "u16") n.remove_suffix(3);
        return digits(n);
    }
    return false;
}

/// The command line, bound to `o`; `quick` for --quick, applied by apply_quick after parsing.
std::unique_ptr<CLI::App> make_app(Options& o, bool& quick) {
    auto app = std::make_unique<CLI::App>(
        "sylva-store-bench: the out-of-core brick store measured: codecs, LMDB against HDF5 chunked datasets, "
        "the streamed build against a dd-like sequential write, cold and warm reads",
        "sylva-store-bench");
    app->footer(
        "Sections: codecs (encode/decode rate and size per codec and level, one thread), backends (the\n"
        "same zstd-1 bricks in LMDB and, when built with it, an HDF5 chunked dataset; cold and warm\n"
        "reads), build (the streamed builder per --build-codecs against a dd-like write of as many\n"
        "bytes, then every brick read cold and warm).\n"
        "Cases: aneurism (../shared/data), aneurismxK (upsampled by K, float32 slices), mlN\n"
        "(procedural Marschner-Lobb N^3, float32, generated slice by slice), mlNu16 (quantised to\n"
        "uint16; ml1024u16 is the issue's 2 GiB volume); NAME-file: NAME's voxels written once to a raw\n"
        "file (untimed), then built from that file with its pages dropped from the page cache before each\n"
        "build. --quick: case ml96, one run, unless --cases or\n"
        "--runs are given. Exit status: 0 on success, 1 on errors (a missing volume), 2 on bad usage.");
    app->add_option("--cases", o.cases, "comma-separated cases (below)")
        ->type_name("LIST")
        ->capture_default_str()
        ->delimiter(',')
        ->check(CLI::Validator(
            [](std::string& v) {
                return known_case(v) ? std::string()
                                     : "'" + v + "' is not a case (aneurism, aneurismxK, mlN, mlNu16)";
            },
            ""));
    app->add_option("--sections", o.sections, "comma-separated sections (below)")
        ->type_name("LIST")
        ->capture_default_str()
        ->delimiter(',')
        ->check(CLI::IsMember({"codecs", "backends", "build"}));
    app->add_option("--brick-format", o.brick_format,
                    "build section: brick samples, as sylva-store build --brick-format (auto: unorm16 for uint8 / "
                    "uint16 sources, float32 otherwise)")
        ->capture_default_str()
        ->check(CLI::IsMember({"auto", "float32", "unorm16", "unorm8"}));
    app->add_option("--build-codecs", o.build_codecs, "codecs of the build section")
        ->type_name("LIST")
        ->capture_default_str()
        ->delimiter(',')
        ->check(CLI::IsMember({"zstd-1", "zstd-fast3", "lz4"}));
    app->add_option("--runs", o.runs, "runs per measurement; medians are reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000));
    app->add_option("--dir", o.dir, "scratch directory for the stores (removed at the end)")
        ->type_name("DIR")
        ->capture_default_str();
    app->add_option("--threads", o.threads, "threads of the builds (default: all)")
        ->type_name("T")
        ->check(CLI::Range(1u, 1024u));
    app->add_option("--json", o.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    app->add_flag("--quick", quick, "the smoke configuration (below)");
    return app;
}

/// --quick's values for the options not given on the command line.
void apply_quick(const CLI::App& app, Options& o) {
    if (app.count("--cases") == 0) o.cases = {"ml96"};
    if (app.count("--runs") == 0) o.runs = 1;
}

bool has(const std::vector<std::string>& v, const char* s) { return std::find(v.begin(), v.end(), s) != v.end(); }

}  // namespace

int main(int argc, char** argv) {
    Options o;
    bool quick = false;
    std::unique_ptr<CLI::App> app = make_app(o, quick);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    if (quick) apply_quick(*app, o);
    try {
        std::filesystem::create_directories(o.dir);
        ThreadPool pool(o.threads);
        bench::Report report;
        for (const std::string& name : o.cases) {
            Case c = make_case(name, o.dir);
            std::cerr << "sylva-store-bench: " << name << "\n";
            if (has(o.sections, "codecs") || has(o.sections, "backends")) {
                auto bricks = case_bricks(c, o.dir, pool, 600);
                if (has(o.sections, "codecs")) codecs_section(c, bricks, o, report);
                if (has(o.sections, "backends")) backends_section(c, bricks, o, report);
            }
            if (has(o.sections, "build")) build_section(c, o, pool, report);
        }
        for (const bench::Record& r : report.records())
            std::printf("%-10s %-16s %-28s %14.3f %s\n", r.case_name.c_str(), r.impl.c_str(), r.metric.c_str(), r.value,
                        r.unit.c_str());
        if (!o.json.empty()) report.write_json(o.json);
        std::filesystem::remove_all(o.dir);
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "sylva-store-bench: " << e.what() << "\n";
        return 1;
    }
}
