// benchmarks/verify.cpp -- telling legitimate disagreements (grazing rays, ties) from wrong ones.
//
// sylva and Embree both intersect spheres analytically in single precision, with different
// formulas: a ray that passes within rounding of a sphere's edge may hit it in one and miss it
// in the other, and two spheres entered at the same t may be reported in either order. Each
// disagreeing ray is re-examined in double precision; the others are "unexplained".
#include <algorithm>
#include <cfloat>
#include <cmath>

#include "bench.hpp"

namespace bench {

namespace {

struct Approach {
    double dist;   ///< distance of the sphere centre from the ray's line
    double entry;  ///< t where the ray enters the sphere (NaN when it misses)
    double slack;  ///< what single-precision rounding can move dist or entry by
};

Approach approach(const sylva::Sphere& s, const sylva::Ray& r) {
    double o[3] = {r.origin.x, r.origin.y, r.origin.z}, d[3] = {r.direction.x, r.direction.y, r.direction.z};
    double c[3] = {s.center.x - o[0], s.center.y - o[1], s.center.z - o[2]};
    double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double tc = (c[0] * d[0] + c[1] * d[1] + c[2] * d[2]) / dd;
    double p2 = 0.0;
    for (int a = 0; a < 3; ++a) p2 += (tc * d[a] - c[a]) * (tc * d[a] - c[a]);
    double rr = double(s.radius) * s.radius;
    double entry = p2 <= rr ? tc - std::sqrt((rr - p2) / dd) : std::nan("");
    double dist_c = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    return {std::sqrt(p2), entry, 8.0 * FLT_EPSILON * (dist_c + s.radius)};
}

/// The ray passes within rounding of the sphere's edge.
bool grazes(const sylva::Sphere& s, const sylva::Ray& r) {
    Approach a = approach(s, r);
    return std::fabs(a.dist - s.radius) <= a.slack;
}

/// The first hits `a` and `b` (kNoHit = none) may both be right: the nearer one grazes its
/// sphere (the other implementation may miss it), or both spheres are entered at the same t.
bool first_explained(std::uint32_t a, std::uint32_t b, const std::vector<sylva::Sphere>& spheres,
                     const sylva::Ray& r) {
    if (a == kNoHit || b == kNoHit) return grazes(spheres[a == kNoHit ? b : a], r);
    Approach pa = approach(spheres[a], r), pb = approach(spheres[b], r);
    if (std::isnan(pa.entry) || std::isnan(pb.entry)) return grazes(spheres[a], r) || grazes(spheres[b], r);
    if (std::fabs(pa.entry - pb.entry) <= std::max(pa.slack, pb.slack)) return true;
    return grazes(spheres[pa.entry < pb.entry ? a : b], r);
}

}  // namespace

std::size_t unexplained(const FirstHits& got, const FirstHits& ref, const std::vector<sylva::Sphere>& spheres,
                        std::span<const sylva::Ray> rays) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < got.id.size(); ++i)
        if (got.id[i] != ref.id[i] && !first_explained(got.id[i], ref.id[i], spheres, rays[i])) ++n;
    return n;
}

std::size_t unexplained(const AllHits& got, const AllHits& ref, const std::vector<sylva::Sphere>& spheres,
                        std::span<const sylva::Ray> rays, const HitList& got_list, const HitList& ref_list) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < got.count.size(); ++i) {
        if (got.count[i] == ref.count[i] && got.set[i] == ref.set[i]) continue;
        std::vector<std::uint32_t> a = got_list(rays[i]), b = ref_list(rays[i]), diff;
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        std::set_symmetric_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(diff));
        bool ok = std::all_of(diff.begin(), diff.end(), [&](std::uint32_t e) { return grazes(spheres[e], rays[i]); });
        n += ok ? 0 : 1;
    }
    return n;
}

}  // namespace bench
