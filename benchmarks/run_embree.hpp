// benchmarks/run_embree.hpp -- Embree 3 as the peer: one RTC_GEOMETRY_TYPE_SPHERE_POINT geometry
// over the same spheres, built at the default quality (RTC_BUILD_QUALITY_MEDIUM), traced with
// rtcIntersect1; all hits through a context filter that records each hit and rejects it.
#ifndef SYLVA_BENCH_RUN_EMBREE_HPP
#define SYLVA_BENCH_RUN_EMBREE_HPP

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

#include <embree3/rtcore.h>
#include <sylva/core/executor.hpp>

#include "bench.hpp"

namespace bench {

class EmbreePeer {
public:
    /// A device with "threads=T" (T = the pool's concurrency). Throws on failure.
    explicit EmbreePeer(std::size_t threads);
    ~EmbreePeer();
    EmbreePeer(const EmbreePeer&) = delete;
    EmbreePeer& operator=(const EmbreePeer&) = delete;

    struct BuildTimes {
        double commit_ms = 0.0;  ///< rtcCommitScene alone
        double setup_ms = 0.0;   ///< scene + geometry + vertex buffer fill + commit
    };
    /// Replaces the scene by one over `spheres` and times it.
    BuildTimes build(const std::vector<sylva::Sphere>& spheres);
    /// Bytes Embree allocated for the current scene (memory monitor; the shared vertex buffer
    /// is ours and not counted).
    [[nodiscard]] std::int64_t scene_bytes() const { return scene_bytes_; }

    /// One pass over all rays into `out` (prepare()d for rays.size(); every entry written).
    void first_hits(std::span<const sylva::Ray> rays, sylva::ThreadPool& pool, FirstHits& out) const;
    void all_hits(std::span<const sylva::Ray> rays, sylva::ThreadPool& pool, AllHits& out) const;
    /// The ids all_hits finds along one ray (for re-examining disagreements).
    [[nodiscard]] HitList hit_list() const;

    /// One ray at a time (callers running their own loops): the nearest hit (prim kNoHit
    /// where none), and all hits in order of entry t (as all_hits finds them) into `out`.
    struct Hit {
        float t;
        std::uint32_t prim;
    };
    [[nodiscard]] Hit first_hit(const sylva::Ray& ray) const;
    void hits_along(const sylva::Ray& ray, std::vector<Hit>& out) const;

private:
    void release_scene();
    void check(const char* what) const;
    static bool monitor(void* self, ssize_t bytes, bool post);

    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    std::vector<float> vertices_;  ///< x, y, z, r per sphere, plus one float4 of padding
    std::atomic<std::int64_t> allocated_{0};
    std::int64_t scene_bytes_ = 0;
};

}  // namespace bench

#endif  // SYLVA_BENCH_RUN_EMBREE_HPP
