// sylva/store/lmdb.hpp -- the few LMDB calls the brick store makes, wrapped so that every failure
// becomes a sylva::Error naming the call and the store, and every handle is released.
// LMDB (Howard Chu, Symas; Debian liblmdb-dev): a B+tree in one memory-mapped file with
// copy-on-write pages, so a committed transaction is durable and an interrupted one (a crash,
// SIGKILL, a full disk) leaves the last committed state -- never a torn store.
#ifndef SYLVA_STORE_LMDB_HPP
#define SYLVA_STORE_LMDB_HPP

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>

#include <lmdb.h>

#include "sylva/core/error.hpp"

namespace sylva::store::lmdb {

/// Throws sylva::Error("store PATH: CALL: lmdb's message") unless rc is MDB_SUCCESS.
inline void check(int rc, const std::string& where, const char* call) {
    if (rc != MDB_SUCCESS) throw Error(where + ": " + call + ": " + mdb_strerror(rc));
}

/// An MDB_env, closed on destruction.
class Env {
public:
    Env() = default;
    explicit Env(const std::string& where) : where_(where) { check(mdb_env_create(&env_), where_, "mdb_env_create"); }
    Env(const Env&) = delete;
    Env& operator=(const Env&) = delete;
    ~Env() {
        if (env_) mdb_env_close(env_);
    }
    [[nodiscard]] MDB_env* get() const { return env_; }
    [[nodiscard]] const std::string& where() const { return where_; }

private:
    MDB_env* env_ = nullptr;
    std::string where_;
};

/// A transaction, aborted on destruction unless committed.
class Txn {
public:
    Txn(const Env& env, unsigned flags) : where_(&env.where()) {
        check(mdb_txn_begin(env.get(), nullptr, flags, &txn_), *where_, "mdb_txn_begin");
    }
    Txn(const Txn&) = delete;
    Txn& operator=(const Txn&) = delete;
    ~Txn() {
        if (txn_) mdb_txn_abort(txn_);
    }
    [[nodiscard]] MDB_txn* get() const { return txn_; }
    /// Commits; returns LMDB's code (MDB_SUCCESS, ENOSPC, MDB_MAP_FULL, ...) for the caller to
    /// report. The transaction is gone either way.
    int commit() {
        int rc = mdb_txn_commit(txn_);
        txn_ = nullptr;
        return rc;
    }

private:
    MDB_txn* txn_ = nullptr;
    const std::string* where_;
};

/// An MDB_val over bytes.
inline MDB_val val(const void* data, std::size_t size) { return MDB_val{size, const_cast<void*>(data)}; }
inline MDB_val val(std::string_view s) { return val(s.data(), s.size()); }
inline std::span<const std::byte> bytes(const MDB_val& v) { return {static_cast<const std::byte*>(v.mv_data), v.mv_size}; }
inline std::string_view text(const MDB_val& v) { return {static_cast<const char*>(v.mv_data), v.mv_size}; }

/// Looks `key` up; false when absent, throws on any other failure.
inline bool get(const Txn& txn, MDB_dbi dbi, MDB_val key, MDB_val& out, const std::string& where) {
    int rc = mdb_get(txn.get(), dbi, &key, &out);
    if (rc == MDB_NOTFOUND) return false;
    check(rc, where, "mdb_get");
    return true;
}

/// A brick key as stored (MDB_INTEGERKEY: a native unsigned int).
inline MDB_val brick_key(const unsigned& key) { return val(&key, sizeof key); }

}  // namespace sylva::store::lmdb

#endif  // SYLVA_STORE_LMDB_HPP
