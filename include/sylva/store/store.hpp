// sylva/store/store.hpp -- the brick store, read side: an octree::BrickSource over an LMDB
// environment on disk (Gobbetti et al., section 5 and Fig. 2: the out-of-core octree database
// behind the CPU and GPU caches; they used Berkeley DB with LZO; sylva uses LMDB with zstd or lz4
// and a checksum per brick -- format: sylva/store/format.hpp).
//
//   auto store = sylva::store::Store::open("aneurism.store");  // throws sylva::Error: missing,
//                                                               // incomplete, newer, truncated
//   std::span<const std::uint32_t> index = store.index();      // == octree::encode(build(grid), HOST)
//   std::vector<std::uint32_t> brick(index[8]);
//   if (store.read_brick(key, brick) == octree::BrickStatus::ok) ...  // any thread
#ifndef SYLVA_STORE_STORE_HPP
#define SYLVA_STORE_STORE_HPP

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/octree/brick_source.hpp"
#include "sylva/store/codec.hpp"
#include "sylva/store/format.hpp"
#include "sylva/store/lmdb.hpp"

namespace sylva::store {

/// What Store::verify found.
struct VerifyReport {
    bool complete = false;                 ///< the store says every brick and the index are in
    bool index_ok = false;                 ///< index present, its checksum and header consistent
    std::uint64_t bricks_checked = 0;      ///< stored bricks decoded
    std::uint64_t bricks_expected = 0;     ///< the build's node count
    std::vector<std::uint32_t> corrupt;    ///< keys whose brick failed to decode or its checksum
    std::vector<std::uint32_t> unexpected; ///< keys outside [0, bricks_expected)
    std::uint64_t missing = 0;             ///< expected keys not stored
    std::uint64_t stored_bytes = 0;        ///< bytes of the stored brick values
    /// True when the store is complete and every check passed.
    [[nodiscard]] bool ok() const {
        return complete && index_ok && corrupt.empty() && unexpected.empty() && missing == 0;
    }
};

/// A brick store opened read-only. Satisfies octree::BrickSource; read_brick is safe from
/// several threads at once. Movable, not copyable.
class Store {
public:
    /// Opens the store at `path` (a directory made by StoreWriter / `sylva-store build`). Throws
    /// sylva::Error naming the store when it is missing, not a store, from a newer format,
    /// truncated, or -- unless `allow_incomplete` -- incomplete (an interrupted build; index()
    /// is then empty and read_brick serves the bricks stored so far).
    static Store open(const std::filesystem::path& path, bool allow_incomplete = false);

    /// The octree's index words (see sylva/octree/brick_source.hpp); empty for an incomplete store.
    [[nodiscard]] std::span<const std::uint32_t> index() const { return index_; }
    /// Reads brick `key` into `out` (exactly brick_words() words): ok, missing (no such key or
    /// wrong size of `out`), or corrupt (failed to decode or its checksum). Never throws for
    /// bad data; throws sylva::Error only when LMDB itself fails.
    octree::BrickStatus read_brick(std::uint32_t key, std::span<std::uint32_t> out) const;

    [[nodiscard]] const BuildInfo& build_info() const { return info_; }
    [[nodiscard]] bool complete() const { return complete_; }
    [[nodiscard]] std::uint32_t brick_words() const { return info_.brick_words(); }
    /// Bricks of the finished store (= nodes).
    [[nodiscard]] std::uint32_t brick_count() const { return info_.node_count; }
    /// Bricks stored when the store was opened.
    [[nodiscard]] std::uint64_t bricks_stored() const { return stored_; }
    /// Format version recorded in the store.
    [[nodiscard]] std::uint32_t format_version() const { return format_; }
    /// Bytes of data.mdb on disk.
    [[nodiscard]] std::uint64_t file_bytes() const { return file_bytes_; }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }

    /// Decodes every stored brick and checks its checksum, the index's checksum and the key
    /// set; `progress(done, total)` is called now and then.
    VerifyReport verify(const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const;
    /// XXH3-64 over the index words and every stored brick's (key, checksum) in key order: two
    /// stores with equal digests hold the same index and bricks (whatever their codec).
    [[nodiscard]] std::uint64_t content_digest() const;
    /// Bytes of the stored brick values (headers and payloads), without decoding them.
    [[nodiscard]] std::uint64_t stored_brick_bytes() const;

private:
    Store() = default;
    [[nodiscard]] std::string where() const { return "store " + path_.string(); }
    void read_meta();

    std::filesystem::path path_;
    std::unique_ptr<lmdb::Env> env_;
    MDB_dbi meta_ = 0, bricks_ = 0;
    BuildInfo info_;
    std::vector<std::uint32_t> index_;
    std::uint32_t format_ = 0;
    bool complete_ = false;
    std::uint64_t stored_ = 0;
    std::uint64_t file_bytes_ = 0;
};

static_assert(octree::BrickSource<Store>);

// ---- implementation ----------------------------------------------------------------------

namespace detail {

/// Unmaps the pages of a value read through LMDB's map once it has been decoded: the pages stay
/// in the page cache, but no longer count in the process's resident set (a renderer reading a
/// store many times its budget would otherwise see its RSS grow with every brick it ever read).
/// The map is shared and read-only, so a later access faults the same bytes back in.
inline void release_pages(const MDB_val& v) {
    static const std::uintptr_t page = std::uintptr_t(::sysconf(_SC_PAGESIZE));
    auto lo = reinterpret_cast<std::uintptr_t>(v.mv_data) & ~(page - 1u);
    auto hi = (reinterpret_cast<std::uintptr_t>(v.mv_data) + v.mv_size + page - 1u) & ~(page - 1u);
    if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_DONTNEED);
}

/// Throws unless data.mdb holds every page LMDB's meta page says is in use (a truncated file
/// would make reads through the map fault, SIGBUS, rather than fail).
inline void check_not_truncated(MDB_env* env, const std::filesystem::path& data, const std::string& where) {
    MDB_envinfo info;
    MDB_stat stat;
    lmdb::check(mdb_env_info(env, &info), where, "mdb_env_info");
    lmdb::check(mdb_env_stat(env, &stat), where, "mdb_env_stat");
    std::error_code ec;
    std::uint64_t size = std::filesystem::file_size(data, ec);
    std::uint64_t need = (std::uint64_t(info.me_last_pgno) + 1u) * stat.ms_psize;
    if (ec || size < need)
        throw Error(where + ": data.mdb is truncated (" + std::to_string(size) + " bytes, its pages need " +
                    std::to_string(need) + ")");
}

}  // namespace detail

inline Store Store::open(const std::filesystem::path& path, bool allow_incomplete) {
    Store s;
    s.path_ = path;
    std::error_code ec;
    const std::filesystem::path data = path / "data.mdb";
    if (!std::filesystem::is_directory(path, ec) || !std::filesystem::is_regular_file(data, ec))
        throw Error(s.where() + ": no such store (expected a directory holding data.mdb, made by sylva-store build)");
    s.file_bytes_ = std::filesystem::file_size(data, ec);
    s.env_ = std::make_unique<lmdb::Env>(s.where());
    lmdb::check(mdb_env_set_maxdbs(s.env_->get(), 4), s.where(), "mdb_env_set_maxdbs");
    lmdb::check(mdb_env_set_maxreaders(s.env_->get(), 256), s.where(), "mdb_env_set_maxreaders");
    lmdb::check(mdb_env_open(s.env_->get(), path.c_str(), MDB_RDONLY | MDB_NOTLS, 0644), s.where(),
                "mdb_env_open");
    detail::check_not_truncated(s.env_->get(), data, s.where());
    s.read_meta();
    if (!s.complete_ && !allow_incomplete)
        throw Error(s.where() + ": incomplete (" + std::to_string(s.stored_) + " of " +
                    std::to_string(s.info_.node_count) +
                    " bricks stored; an interrupted build): finish it with sylva-store build ... --resume");
    return s;
}

inline void Store::read_meta() {
    {
        // Database handles opened in a transaction outlive it only when it commits.
        lmdb::Txn open(*env_, MDB_RDONLY);
        if (mdb_dbi_open(open.get(), "meta", 0, &meta_) != MDB_SUCCESS ||
            mdb_dbi_open(open.get(), "bricks", MDB_INTEGERKEY, &bricks_) != MDB_SUCCESS)
            throw Error(where() + ": not a sylva brick store (no meta and bricks databases)");
        lmdb::check(open.commit(), where(), "mdb_txn_commit");
    }
    lmdb::Txn txn(*env_, MDB_RDONLY);
    MDB_val v;
    if (!lmdb::get(txn, meta_, lmdb::val("magic"), v, where()) || lmdb::text(v) != kMagic)
        throw Error(where() + ": not a sylva brick store (no magic)");
    if (!lmdb::get(txn, meta_, lmdb::val("format"), v, where()) || v.mv_size != 4)
        throw Error(where() + ": no format version");
    std::memcpy(&format_, v.mv_data, 4);
    if (format_ > kFormatVersion)
        throw Error(where() + ": format version " + std::to_string(format_) + " is newer than this sylva reads (" +
                    std::to_string(kFormatVersion) + "); use a newer sylva or rebuild the store");
    if (!lmdb::get(txn, meta_, lmdb::val("build"), v, where())) throw Error(where() + ": no build info");
    info_ = build_info_from_text(lmdb::text(v));
    MDB_stat st;
    lmdb::check(mdb_stat(txn.get(), bricks_, &st), where(), "mdb_stat");
    stored_ = st.ms_entries;
    complete_ = lmdb::get(txn, meta_, lmdb::val("complete"), v, where());
    if (!complete_) return;
    MDB_val sum;
    if (!lmdb::get(txn, meta_, lmdb::val("index"), v, where()) || v.mv_size % 4 != 0 ||
        !lmdb::get(txn, meta_, lmdb::val("index_xxh3"), sum, where()) || sum.mv_size != 8)
        throw Error(where() + ": complete, but its index is missing");
    index_.resize(v.mv_size / 4);
    std::memcpy(index_.data(), v.mv_data, v.mv_size);
    std::uint64_t want;
    std::memcpy(&want, sum.mv_data, 8);
    if (XXH3_64bits(index_.data(), v.mv_size) != want) throw Error(where() + ": the index fails its checksum");
    if (index_.size() < SYLVA_OCT_HEADER_WORDS || index_[6] != info_.node_count || index_[7] != info_.node_count ||
        index_[8] != info_.brick_words() || (index_[5] >> 24) != static_cast<std::uint32_t>(info_.brick_format))
        throw Error(where() + ": the index does not match the build info");
}

inline octree::BrickStatus Store::read_brick(std::uint32_t key, std::span<std::uint32_t> out) const {
    if (out.size() != brick_words() || key >= brick_count()) return octree::BrickStatus::missing;
    lmdb::Txn txn(*env_, MDB_RDONLY);
    unsigned k = key;
    MDB_val v;
    if (!lmdb::get(txn, bricks_, lmdb::brick_key(k), v, where())) return octree::BrickStatus::missing;
    DecodeStatus d = decode_brick(lmdb::bytes(v), out);
    detail::release_pages(v);
    return d == DecodeStatus::ok ? octree::BrickStatus::ok : octree::BrickStatus::corrupt;
}

inline VerifyReport Store::verify(const std::function<void(std::uint64_t, std::uint64_t)>& progress) const {
    VerifyReport r;
    r.complete = complete_;
    r.index_ok = complete_ && !index_.empty();  // read_meta checked its checksum and header
    r.bricks_expected = info_.node_count;
    lmdb::Txn txn(*env_, MDB_RDONLY);
    MDB_cursor* cur = nullptr;
    lmdb::check(mdb_cursor_open(txn.get(), bricks_, &cur), where(), "mdb_cursor_open");
    std::vector<std::uint32_t> words(brick_words());
    MDB_val k, v;
    std::uint64_t expected_seen = 0;
    for (int rc = mdb_cursor_get(cur, &k, &v, MDB_FIRST); rc == MDB_SUCCESS; rc = mdb_cursor_get(cur, &k, &v, MDB_NEXT)) {
        unsigned key = 0;
        if (k.mv_size == sizeof key) std::memcpy(&key, k.mv_data, sizeof key);
        r.stored_bytes += v.mv_size;
        ++r.bricks_checked;
        if (k.mv_size != sizeof key || key >= info_.node_count) {
            r.unexpected.push_back(key);
            continue;
        }
        ++expected_seen;
        if (decode_brick(lmdb::bytes(v), words) != DecodeStatus::ok) r.corrupt.push_back(key);
        detail::release_pages(v);
        if (progress && (r.bricks_checked & 255u) == 0u) progress(r.bricks_checked, stored_);
    }
    mdb_cursor_close(cur);
    r.missing = info_.node_count - expected_seen;
    if (progress) progress(r.bricks_checked, stored_);
    return r;
}

inline std::uint64_t Store::content_digest() const {
    XXH3_state_t* st = XXH3_createState();
    XXH3_64bits_reset(st);
    XXH3_64bits_update(st, index_.data(), index_.size() * 4u);
    lmdb::Txn txn(*env_, MDB_RDONLY);
    MDB_cursor* cur = nullptr;
    lmdb::check(mdb_cursor_open(txn.get(), bricks_, &cur), where(), "mdb_cursor_open");
    MDB_val k, v;
    for (int rc = mdb_cursor_get(cur, &k, &v, MDB_FIRST); rc == MDB_SUCCESS; rc = mdb_cursor_get(cur, &k, &v, MDB_NEXT)) {
        std::uint64_t sum = stored_checksum(lmdb::bytes(v));
        XXH3_64bits_update(st, k.mv_data, k.mv_size);
        XXH3_64bits_update(st, &sum, sizeof sum);
    }
    mdb_cursor_close(cur);
    std::uint64_t d = XXH3_64bits_digest(st);
    XXH3_freeState(st);
    return d;
}

inline std::uint64_t Store::stored_brick_bytes() const {
    lmdb::Txn txn(*env_, MDB_RDONLY);
    MDB_cursor* cur = nullptr;
    lmdb::check(mdb_cursor_open(txn.get(), bricks_, &cur), where(), "mdb_cursor_open");
    MDB_val k, v;
    std::uint64_t bytes = 0;
    for (int rc = mdb_cursor_get(cur, &k, &v, MDB_FIRST); rc == MDB_SUCCESS; rc = mdb_cursor_get(cur, &k, &v, MDB_NEXT))
        bytes += v.mv_size;
    mdb_cursor_close(cur);
    return bytes;
}

}  // namespace sylva::store

#endif  // SYLVA_STORE_STORE_HPP
