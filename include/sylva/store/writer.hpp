// sylva/store/writer.hpp -- the brick store, write side: creates (or resumes) a store, adds
// encoded bricks in batches of committed transactions, and marks it complete with the index.
// Layout: sylva/store/format.hpp. Crash safety comes from LMDB: a commit is atomic and durable
// (fsync), so after kill -9 or a full disk the store holds exactly the committed batches and
// no "complete" key.
#ifndef SYLVA_STORE_WRITER_HPP
#define SYLVA_STORE_WRITER_HPP

#include <sys/statvfs.h>

#include <cerrno>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/store/codec.hpp"
#include "sylva/store/format.hpp"
#include "sylva/store/lmdb.hpp"

namespace sylva::store {

/// Settings of StoreWriter.
struct WriterConfig {
    /// Largest size the store may grow to (LMDB's map size: address space, not disk, is
    /// reserved). 1 TiB by default; a store that reaches it fails like a full disk.
    std::uint64_t map_bytes = std::uint64_t{1} << 40;
    /// Bytes of encoded bricks per committed transaction: each commit is an fsync, so larger
    /// batches write faster and a crash loses at most one batch.
    std::uint64_t batch_bytes = std::uint64_t{64} << 20;
    /// Bricks per committed transaction at most (0 = no limit; tests use small batches).
    std::uint64_t batch_bricks = 0;
};

/// Free bytes for unprivileged users on the file system holding `dir` (0 when unknown).
inline std::uint64_t free_bytes(const std::filesystem::path& dir) {
    struct statvfs s {};
    if (statvfs(dir.c_str(), &s) != 0) return 0;
    return std::uint64_t(s.f_bavail) * s.f_frsize;
}

/// Human-readable bytes: "1.5 GiB".
inline std::string bytes_text(double b) {
    const char* unit[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int u = 0;
    while (b >= 1024.0 && u < 4) b /= 1024.0, ++u;
    char buf[32];
    std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", b, unit[u]);
    return buf;
}

/// Thrown when the disk (or the map size) is full: the store keeps its committed bricks and
/// stays incomplete. what() says how much was written and how much more is needed.
class DiskFullError : public Error {
public:
    using Error::Error;
};

/// Writes a brick store. Not thread-safe (one writer; encode bricks on other threads).
class StoreWriter {
public:
    /// Creates a new store at `path` (which must not exist: a store is never overwritten), or,
    /// with `resume`, reopens an incomplete one whose BuildInfo equals `info` (throws naming the
    /// first difference otherwise, and when it is already complete).
    static StoreWriter create(const std::filesystem::path& path, const BuildInfo& info, bool resume,
                              const WriterConfig& cfg = {});

    /// True when brick `key` is already stored (a resumed build skips it).
    [[nodiscard]] bool has(std::uint32_t key) const;
    /// Per key below the node count, 1 when that brick is stored (one cursor pass).
    [[nodiscard]] std::vector<char> stored_keys() const;
    /// Adds an encoded brick (sylva/store/codec.hpp); commits when the batch is full.
    void put(std::uint32_t key, std::span<const std::byte> encoded);
    /// Commits the current batch.
    void commit();
    /// Writes the index, marks the store complete and commits.
    void finish(std::span<const std::uint32_t> index);
    /// Bricks stored (committed or in the open batch).
    [[nodiscard]] std::uint64_t stored() const { return stored_; }
    /// Encoded brick bytes written by this writer.
    [[nodiscard]] std::uint64_t bytes_written() const { return written_; }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }

private:
    StoreWriter() = default;
    [[nodiscard]] std::string where() const { return "store " + path_.string(); }
    void begin();
    [[noreturn]] void fail_full(int rc);
    void put_meta(std::string_view key, const void* data, std::size_t size);

    std::filesystem::path path_;
    WriterConfig cfg_;
    BuildInfo info_;
    std::unique_ptr<lmdb::Env> env_;
    std::unique_ptr<lmdb::Txn> txn_;
    MDB_dbi meta_ = 0, bricks_ = 0;
    std::uint64_t stored_ = 0, written_ = 0, batch_bytes_ = 0, batch_bricks_ = 0;
};

// ---- implementation ----------------------------------------------------------------------

inline StoreWriter StoreWriter::create(const std::filesystem::path& path, const BuildInfo& info, bool resume,
                                       const WriterConfig& cfg) {
    StoreWriter w;
    w.path_ = path;
    w.cfg_ = cfg;
    w.info_ = info;
    std::error_code ec;
    bool exists = std::filesystem::exists(path, ec);
    if (exists && !resume)
        throw Error(w.where() + ": already exists; a store is never overwritten (remove it, or add --resume to finish "
                                "an interrupted build)");
    if (!exists && resume) throw Error(w.where() + ": --resume, but there is no such store");
    if (!exists && !std::filesystem::create_directory(path, ec))
        throw Error(w.where() + ": cannot create the directory" + (ec ? ": " + ec.message() : std::string()));
    if (exists && !std::filesystem::is_regular_file(path / "data.mdb", ec) &&
        !std::filesystem::is_empty(path, ec) && !std::filesystem::exists(path / "lock.mdb", ec))
        throw Error(w.where() + ": not a brick store (no data.mdb)");
    w.env_ = std::make_unique<lmdb::Env>(w.where());
    MDB_env* env = w.env_->get();
    lmdb::check(mdb_env_set_maxdbs(env, 4), w.where(), "mdb_env_set_maxdbs");
    lmdb::check(mdb_env_set_mapsize(env, cfg.map_bytes), w.where(), "mdb_env_set_mapsize");
    lmdb::check(mdb_env_open(env, path.c_str(), MDB_NOTLS, 0644), w.where(), "mdb_env_open");
    lmdb::Txn txn(*w.env_, 0);
    lmdb::check(mdb_dbi_open(txn.get(), "meta", MDB_CREATE, &w.meta_), w.where(), "mdb_dbi_open meta");
    lmdb::check(mdb_dbi_open(txn.get(), "bricks", MDB_CREATE | MDB_INTEGERKEY, &w.bricks_), w.where(),
                "mdb_dbi_open bricks");
    MDB_val v;
    // A build killed before its first commit left no meta: resuming it starts it afresh.
    if (resume && lmdb::get(txn, w.meta_, lmdb::val("magic"), v, w.where())) {
        if (lmdb::text(v) != kMagic) throw Error(w.where() + ": not a sylva brick store");
        std::uint32_t format = 0;
        if (lmdb::get(txn, w.meta_, lmdb::val("format"), v, w.where()) && v.mv_size == 4) std::memcpy(&format, v.mv_data, 4);
        if (format != kFormatVersion)
            throw Error(w.where() + ": format version " + std::to_string(format) + ", this sylva writes " +
                        std::to_string(kFormatVersion) + "; cannot resume it");
        if (lmdb::get(txn, w.meta_, lmdb::val("complete"), v, w.where()))
            throw Error(w.where() + ": already complete; nothing to resume");
        if (!lmdb::get(txn, w.meta_, lmdb::val("build"), v, w.where()) || build_info_from_text(lmdb::text(v)) != info)
            throw Error(w.where() + ": was started with other settings or input; --resume needs the same command:\n" +
                        std::string(lmdb::text(v)) + "now:\n" + to_text(info));
        MDB_stat st;
        lmdb::check(mdb_stat(txn.get(), w.bricks_, &st), w.where(), "mdb_stat");
        w.stored_ = st.ms_entries;
    } else {
        std::uint32_t format = kFormatVersion;
        std::string build = to_text(info);
        MDB_val k = lmdb::val("magic"), m = lmdb::val(kMagic);
        lmdb::check(mdb_put(txn.get(), w.meta_, &k, &m, 0), w.where(), "mdb_put magic");
        k = lmdb::val("format"), m = lmdb::val(&format, 4);
        lmdb::check(mdb_put(txn.get(), w.meta_, &k, &m, 0), w.where(), "mdb_put format");
        k = lmdb::val("build"), m = lmdb::val(build);
        lmdb::check(mdb_put(txn.get(), w.meta_, &k, &m, 0), w.where(), "mdb_put build");
    }
    int rc = txn.commit();
    if (rc != MDB_SUCCESS) w.fail_full(rc);
    return w;
}

inline bool StoreWriter::has(std::uint32_t key) const {
    unsigned k = key;
    MDB_val v;
    if (txn_) return lmdb::get(*txn_, bricks_, lmdb::brick_key(k), v, where());
    lmdb::Txn txn(*env_, MDB_RDONLY);
    return lmdb::get(txn, bricks_, lmdb::brick_key(k), v, where());
}

inline std::vector<char> StoreWriter::stored_keys() const {
    std::vector<char> out(info_.node_count, 0);
    lmdb::Txn txn(*env_, MDB_RDONLY);
    MDB_cursor* cur = nullptr;
    lmdb::check(mdb_cursor_open(txn.get(), bricks_, &cur), where(), "mdb_cursor_open");
    MDB_val k, v;
    for (int rc = mdb_cursor_get(cur, &k, &v, MDB_FIRST); rc == MDB_SUCCESS; rc = mdb_cursor_get(cur, &k, &v, MDB_NEXT)) {
        unsigned key = 0;
        if (k.mv_size != sizeof key) continue;
        std::memcpy(&key, k.mv_data, sizeof key);
        if (key < out.size()) out[key] = 1;
    }
    mdb_cursor_close(cur);
    return out;
}

inline void StoreWriter::begin() {
    if (!txn_) txn_ = std::make_unique<lmdb::Txn>(*env_, 0);
}

inline void StoreWriter::fail_full(int rc) {
    txn_.reset();
    if (rc == MDB_MAP_FULL || rc == ENOSPC || rc == EDQUOT) {
        double per_brick = stored_ ? double(written_) / double(stored_) : 0.0;
        double left = per_brick * double(info_.node_count > stored_ ? info_.node_count - stored_ : 0u);
        throw DiskFullError(where() + ": " + (rc == MDB_MAP_FULL ? "reached its map size" : "the disk is full") + " (" +
                            mdb_strerror(rc) + ") after " + std::to_string(stored_) + " of " +
                            std::to_string(info_.node_count) + " bricks were committed; about " +
                            bytes_text(left * 1.1) + " more are needed (" + bytes_text(double(free_bytes(path_))) +
                            " free). The store is incomplete, not corrupt: free space and run the same command "
                            "with --resume");
    }
    throw Error(where() + ": commit failed: " + mdb_strerror(rc));
}

inline void StoreWriter::put(std::uint32_t key, std::span<const std::byte> encoded) {
    begin();
    unsigned k = key;
    MDB_val kv = lmdb::brick_key(k), v = lmdb::val(encoded.data(), encoded.size());
    int rc = mdb_put(txn_->get(), bricks_, &kv, &v, 0);
    if (rc == MDB_MAP_FULL || rc == ENOSPC) fail_full(rc);
    lmdb::check(rc, where(), "mdb_put");
    ++stored_;
    written_ += encoded.size();
    batch_bytes_ += encoded.size();
    ++batch_bricks_;
    if (batch_bytes_ >= cfg_.batch_bytes || (cfg_.batch_bricks && batch_bricks_ >= cfg_.batch_bricks)) commit();
}

inline void StoreWriter::commit() {
    batch_bytes_ = batch_bricks_ = 0;
    if (!txn_) return;
    int rc = txn_->commit();
    txn_.reset();
    if (rc != MDB_SUCCESS) fail_full(rc);
}

inline void StoreWriter::put_meta(std::string_view key, const void* data, std::size_t size) {
    MDB_val k = lmdb::val(key), v = lmdb::val(data, size);
    int rc = mdb_put(txn_->get(), meta_, &k, &v, 0);
    if (rc == MDB_MAP_FULL || rc == ENOSPC) fail_full(rc);
    lmdb::check(rc, where(), "mdb_put");
}

inline void StoreWriter::finish(std::span<const std::uint32_t> index) {
    commit();
    {
        lmdb::Txn txn(*env_, MDB_RDONLY);
        MDB_stat st;
        lmdb::check(mdb_stat(txn.get(), bricks_, &st), where(), "mdb_stat");
        if (st.ms_entries != info_.node_count)
            throw Error(where() + ": " + std::to_string(st.ms_entries) + " bricks stored, " +
                        std::to_string(info_.node_count) + " expected; not marked complete");
    }
    begin();
    std::uint64_t sum = XXH3_64bits(index.data(), index.size_bytes());
    std::uint64_t count = info_.node_count;
    put_meta("index", index.data(), index.size_bytes());
    put_meta("index_xxh3", &sum, sizeof sum);
    put_meta("complete", &count, sizeof count);
    commit();
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_WRITER_HPP
