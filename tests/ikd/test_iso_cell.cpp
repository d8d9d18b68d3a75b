// The ray-isosurface intersection inside one trilinear cell (sylva/shared/iso_cell.h) against an
// independent double-precision reference: the trilinear function evaluated directly in double
// (never through the cubic), sampled densely along the ray for the first sign change or exact
// zero, then bisected. Plus hand-made hard cases with exact answers (grazing and tangent rays,
// double roots, corners on the surface, constant cells, zero direction components, magnitudes).
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include <sylva/shared/iso_cell.h>

namespace {

namespace sh = sylva::shared;
using glm::dvec3;
using glm::vec3;
using glm::vec4;

/// Corner i = x + 2y + 4z of the cell (lo holds z = 0, hi z = 1).
double corner(vec4 lo, vec4 hi, int i) {
    vec4 v = (i < 4) ? lo : hi;
    return double(v[i & 3]);
}

/// Trilinear density in double, summed corner by corner (independent of the header's blends).
double rho_ref(vec4 lo, vec4 hi, dvec3 p) {
    double s = 0.0;
    for (int i = 0; i < 8; ++i) {
        double wx = (i & 1) ? p.x : 1.0 - p.x;
        double wy = (i & 2) ? p.y : 1.0 - p.y;
        double wz = (i & 4) ? p.z : 1.0 - p.z;
        s += corner(lo, hi, i) * wx * wy * wz;
    }
    return s;
}

/// max |c - iso| over the corners, in double.
double scale_ref(vec4 lo, vec4 hi, float iso) {
    double m = 0.0;
    for (int i = 0; i < 8; ++i) m = std::max(m, std::abs(corner(lo, hi, i) - double(iso)));
    return m;
}

struct Case {
    vec4 lo, hi;
    vec3 o, d;
    float t0, t1, iso;
};

/// g(t) = rho(o + t d) - iso in double, from the float inputs.
double g_ref(const Case& c, double t) {
    dvec3 p = dvec3(c.o) + t * dvec3(c.d);
    return rho_ref(c.lo, c.hi, p) - double(c.iso);
}

/// What the reference sees on [t0, t1].
struct Ref {
    bool crossing = false;  ///< a sign change or exact zero was found
    double t = 0.0;         ///< the first one
    double min_abs = 0.0;   ///< min |g| over the samples
    bool clean = false;     ///< crossing with a steep slope and nothing close to zero before it
};

constexpr int kSteps = 4096;

/// Dense sampling (kSteps steps) for the first sign change or zero, then bisection in double.
Ref reference(const Case& c) {
    Ref r;
    double t0 = c.t0, t1 = c.t1, len = t1 - t0;
    double m = scale_ref(c.lo, c.hi, c.iso);
    std::array<double, kSteps + 1> g{};
    r.min_abs = std::numeric_limits<double>::infinity();
    int first = -1;
    for (int k = 0; k <= kSteps; ++k) {
        g[k] = g_ref(c, t0 + len * k / kSteps);
        r.min_abs = std::min(r.min_abs, std::abs(g[k]));
        if (first < 0 && (g[k] == 0.0 || (k > 0 && (g[k] < 0.0) != (g[k - 1] < 0.0)))) first = k;
    }
    if (first < 0) return r;
    r.crossing = true;
    if (g[first] == 0.0) {
        r.t = t0 + len * first / kSteps;
    } else {
        double a = t0 + len * (first - 1) / kSteps, b = t0 + len * first / kSteps, ga = g[first - 1];
        for (int i = 0; i < 200 && a < b; ++i) {
            double mid = 0.5 * (a + b), gm = g_ref(c, mid);
            if (gm == 0.0) a = b = mid;
            else if ((gm < 0.0) == (ga < 0.0)) a = mid, ga = gm;
            else b = mid;
        }
        r.t = 0.5 * (a + b);
    }
    // Clean: slope |dg/du| (u = fraction of [t0, t1]) at least 1e-2 M, no sample within 1e-5 M
    // of zero more than 1e-3 of the interval before it, no second sign change within 1e-3 after.
    double u = (len > 0.0) ? (r.t - t0) / len : 0.0;
    double h = 1e-6;
    double slope = (g_ref(c, r.t + h * len) - g_ref(c, r.t - h * len)) / (2.0 * h);
    r.clean = len > 0.0 && m > 0.0 && std::abs(slope) >= 1e-2 * m;
    for (int k = 0; k <= kSteps && r.clean; ++k) {
        double uk = double(k) / kSteps;
        if (uk < u - 1e-3 && std::abs(g[k]) < 1e-5 * m) r.clean = false;
        if (uk > u + 1.0 / kSteps && uk <= u + 1e-3 && k > 0 && (g[k] < 0.0) != (g[k - 1] < 0.0)) r.clean = false;
    }
    return r;
}

/// Ray interval inside [0, 1]^3 in double (slab test); empty when lo > hi.
void slab(dvec3 o, dvec3 d, double& lo, double& hi) {
    lo = -std::numeric_limits<double>::infinity();
    hi = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < 0.0 || o[a] > 1.0) lo = 1.0, hi = 0.0;
            continue;
        }
        double ta = (0.0 - o[a]) / d[a], tb = (1.0 - o[a]) / d[a];
        lo = std::max(lo, std::min(ta, tb));
        hi = std::min(hi, std::max(ta, tb));
    }
}

/// Random vectors drawn component by component in order (the order of arguments in one
/// expression is unspecified, so the cases would differ between compilers).
template <class Dist>
vec4 draw4(std::mt19937& rng, Dist& dist) {
    vec4 v;
    for (int i = 0; i < 4; ++i) v[i] = dist(rng);
    return v;
}
template <class Dist>
vec3 draw3(std::mt19937& rng, Dist& dist) {
    vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = dist(rng);
    return v;
}

/// A random cell (corners in [0, amp]), iso in [0, amp] (half of them uniform, half the density
/// at a random point of the segment), and a ray through [0, 1]^3 with its interval there: a
/// quarter start inside (t0 = 0), a tenth have a zero direction component, the direction length
/// varies over [1/4, 4].
Case random_case(std::mt19937& rng, float amp) {
    std::uniform_real_distribution<float> u01(0.0f, 1.0f), u_out(-1.0f, 2.0f), u_len(-2.0f, 2.0f);
    for (;;) {
        Case c;
        c.lo = draw4(rng, u01) * amp;
        c.hi = draw4(rng, u01) * amp;
        c.iso = u01(rng) * amp;
        bool inside = u01(rng) < 0.25f;
        vec3 target = draw3(rng, u01);
        c.o = inside ? draw3(rng, u01) : draw3(rng, u_out);
        vec3 d = target - c.o;
        if (u01(rng) < 0.1f) {  // axis-parallel in one component
            int a = int(u01(rng) * 3.0f) % 3;
            d[a] = 0.0f;
            c.o[a] = target[a];
        }
        if (glm::length(d) < 1e-3f) continue;
        c.d = glm::normalize(d) * std::exp2(u_len(rng));
        double lo, hi;
        slab(dvec3(c.o), dvec3(c.d), lo, hi);
        if (inside) lo = 0.0;
        if (!(lo <= hi) || lo < 0.0) continue;
        c.t0 = float(lo);
        c.t1 = std::max(float(hi), c.t0);
        if (u01(rng) < 0.5f) {  // half the isovalues are taken on the segment: more crossings
            double t = double(c.t0) + double(u01(rng)) * (double(c.t1) - double(c.t0));
            c.iso = float(rho_ref(c.lo, c.hi, dvec3(c.o) + t * dvec3(c.d)));
        }
        return c;
    }
}

bool hit_of(const Case& c, float& t) {
    return sh::sylva_iso_cell_hit(c.lo, c.hi, c.o, c.d, c.t0, c.t1, c.iso, t);
}

std::string describe(const Case& c, bool hit, float t, const Ref& r) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "lo=(%.9g %.9g %.9g %.9g) hi=(%.9g %.9g %.9g %.9g) o=(%.9g %.9g %.9g) d=(%.9g %.9g %.9g) "
                  "t=[%.9g, %.9g] iso=%.9g | hit=%d t=%.9g | ref crossing=%d t=%.12g clean=%d min|g|=%.3g",
                  c.lo.x, c.lo.y, c.lo.z, c.lo.w, c.hi.x, c.hi.y, c.hi.z, c.hi.w, c.o.x, c.o.y, c.o.z, c.d.x, c.d.y,
                  c.d.z, c.t0, c.t1, c.iso, int(hit), t, int(r.crossing), r.t, int(r.clean), r.min_abs);
    return buf;
}

/// Largest |g| strictly between a reference zero at ta and a later reported hit at tb (sampled
/// at the dense spacing): a hit after a clear excursion of g past zero skipped a real crossing,
/// one after a dip of float-rounding size (a near double root) did not.
double skipped_excursion(const Case& c, double ta, double tb) {
    double step = (double(c.t1) - double(c.t0)) / kSteps, worst = 0.0;
    int n = std::min(kSteps, int((tb - ta) / step) + 1);
    for (int k = 1; k < n; ++k) worst = std::max(worst, std::abs(g_ref(c, ta + (tb - ta) * k / n)));
    return worst;
}

struct Stats {
    int hits = 0, misses = 0, ambiguous = 0, failures = 0;
    double max_err = 0.0;  ///< max |t - t_ref| / max(1, t1 - t0) over clean crossings
    double max_g = 0.0;    ///< max |g(t_hit)| / M over all reported hits
    std::string first_failure;
};

/// Runs n random cases and checks the three properties of the brief against the reference.
Stats random_run(std::uint32_t seed, int n, float amp) {
    std::mt19937 rng(seed);
    Stats s;
    for (int i = 0; i < n; ++i) {
        Case c = random_case(rng, amp);
        float t = 0.0f;
        bool hit = hit_of(c, t);
        Ref r = reference(c);
        double m = scale_ref(c.lo, c.hi, c.iso), len = double(c.t1) - double(c.t0), unit = std::max(1.0, len);
        bool bad = false;
        if (r.clean) {
            ++s.hits;
            double err = hit ? std::abs(double(t) - r.t) / unit : 1.0;
            s.max_err = std::max(s.max_err, err);
            bad = !hit || err > 2e-5;
        } else if (!r.crossing && r.min_abs > 1e-4 * m) {
            ++s.misses;
            bad = hit;
        } else {
            ++s.ambiguous;
        }
        if (hit) {  // every reported hit: on the surface, inside [t0, t1], not after a crossing
            if (m > 0.0) s.max_g = std::max(s.max_g, std::abs(g_ref(c, t)) / m);
            bad = bad || std::abs(g_ref(c, t)) > 5e-6 * m || t < c.t0 || t > c.t1;
            bad = bad || (r.crossing && double(t) > r.t + 1e-5 * unit && skipped_excursion(c, r.t, t) > 1e-5 * m);
        }
        if (bad && s.failures++ == 0) s.first_failure = describe(c, hit, t, r);
    }
    return s;
}

void print_stats(const char* corners, const Stats& s) {
    std::printf("iso cell, random corners in %s: %d clean hits, %d clean misses, %d ambiguous; max |t - t_ref| / "
                "max(1, t1 - t0) = %.3g, max |g(t_hit)| / M = %.3g\n",
                corners, s.hits, s.misses, s.ambiguous, s.max_err, s.max_g);
}

vec4 splat(float v) { return vec4(v, v, v, v); }

/// Corners from a cubic along the main diagonal: rho(u, u, u) = iso + p(u) with p given in
/// Bernstein form (b0, b1, b2, b3): c000 = b0, the three corners next to it b1, the next three
/// b2, c111 = b3.
void diagonal_cell(float iso, vec4 b, vec4& lo, vec4& hi) {
    lo = vec4(iso + b.x, iso + b.y, iso + b.y, iso + b.z);
    hi = vec4(iso + b.y, iso + b.z, iso + b.z, iso + b.w);
}

/// Double-precision bisection of g on [a, b] (signs must differ).
double bisect(const Case& c, double a, double b) {
    double ga = g_ref(c, a);
    for (int i = 0; i < 200; ++i) {
        double mid = 0.5 * (a + b), gm = g_ref(c, mid);
        if ((gm < 0.0) == (ga < 0.0)) a = mid, ga = gm;
        else b = mid;
    }
    return 0.5 * (a + b);
}

}  // namespace

TEST_CASE("iso cell density: exact at the corners and equal to the double reference inside", "[ikd][cell]") {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int n = 0; n < 2000; ++n) {
        float amp = (n % 2 == 0) ? 1.0f : 1e4f;
        vec4 lo = draw4(rng, u) * amp;
        vec4 hi = draw4(rng, u) * amp;
        for (int i = 0; i < 8; ++i) {
            vec3 p(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
            REQUIRE(double(sh::sylva_iso_cell_density(lo, hi, p)) == corner(lo, hi, i));
        }
        vec3 p = draw3(rng, u);
        REQUIRE(std::abs(double(sh::sylva_iso_cell_density(lo, hi, p)) - rho_ref(lo, hi, dvec3(p))) <= 1e-6 * amp);
    }
}

TEST_CASE("iso cell gradient equals central differences of the density", "[ikd][cell]") {
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int n = 0; n < 2000; ++n) {
        float amp = (n % 2 == 0) ? 1.0f : 1e4f;
        vec4 lo = draw4(rng, u) * amp;
        vec4 hi = draw4(rng, u) * amp;
        vec3 p = draw3(rng, u);
        vec3 g = sh::sylva_iso_cell_gradient(lo, hi, p);
        for (int a = 0; a < 3; ++a) {
            // The density is linear along each axis: central differences are exact up to rounding.
            dvec3 e(0.0);
            e[a] = 0.25;
            double ref = (rho_ref(lo, hi, dvec3(p) + e) - rho_ref(lo, hi, dvec3(p) - e)) / 0.5;
            vec3 ef(0.0f);
            ef[a] = 0.25f;
            double lib = (double(sh::sylva_iso_cell_density(lo, hi, p + ef)) -
                          double(sh::sylva_iso_cell_density(lo, hi, p - ef))) / 0.5;
            INFO("axis " << a << " gradient " << g[a] << " reference " << ref << " float differences " << lib);
            REQUIRE(std::abs(double(g[a]) - ref) <= 1e-6 * amp);
            REQUIRE(std::abs(double(g[a]) - lib) <= 1e-5 * amp);
        }
    }
    // One hand-made cell: rho = x + 2y + 4z + xyz.
    vec4 lo(0.0f, 1.0f, 2.0f, 3.0f), hi(4.0f, 5.0f, 6.0f, 8.0f);
    vec3 g = sh::sylva_iso_cell_gradient(lo, hi, vec3(0.5f, 0.25f, 0.75f));
    REQUIRE(g.x == 1.0f + 0.25f * 0.75f);
    REQUIRE(g.y == 2.0f + 0.5f * 0.75f);
    REQUIRE(g.z == 4.0f + 0.5f * 0.25f);
}

TEST_CASE("iso cell cubic equals the direct density along the ray", "[ikd][cell]") {
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
    for (int n = 0; n < 2000; ++n) {
        float amp = (n % 2 == 0) ? 1.0f : 1e4f;
        vec4 lo = draw4(rng, u) * amp;
        vec4 hi = draw4(rng, u) * amp;
        vec3 o = draw3(rng, u);
        vec3 d = draw3(rng, s);
        if (n % 7 == 0) d.y = 0.0f;
        vec4 k = sh::sylva_iso_cell_cubic(lo, hi, o, d);
        for (double t : {-1.0, -0.3, 0.0, 0.25, 0.5, 1.0, 1.7}) {
            double cubic = ((double(k.x) * t + double(k.y)) * t + double(k.z)) * t + double(k.w);
            double direct = rho_ref(lo, hi, dvec3(o) + t * dvec3(d));
            INFO("t " << t << " cubic " << cubic << " direct " << direct);
            REQUIRE(std::abs(cubic - direct) <= 1e-5 * amp);
            double horner = double(sh::sylva_iso_cubic_eval(k, float(t)));
            REQUIRE(std::abs(horner - direct) <= 1e-5 * amp);
        }
    }
    // rho = x + 2y + 4z + xyz along o = 0, d = (1, 1, 1): 7t + t^3.
    vec4 k = sh::sylva_iso_cell_cubic(vec4(0.0f, 1.0f, 2.0f, 3.0f), vec4(4.0f, 5.0f, 6.0f, 8.0f), vec3(0.0f),
                                      vec3(1.0f));
    REQUIRE(k == vec4(1.0f, 0.0f, 7.0f, 0.0f));
}

TEST_CASE("iso cell hit agrees with the double reference on 100000 random cells and rays", "[ikd][cell]") {
    Stats s = random_run(20240611u, 100000, 1.0f);
    print_stats("[0, 1]", s);
    INFO("first failure: " << s.first_failure);
    CHECK(s.failures == 0);
    CHECK(s.max_err <= 2e-5);
    // Not vacuous: both outcomes are common, ambiguous cases rare.
    CHECK(s.hits > 30000);
    CHECK(s.misses > 30000);
    CHECK(s.ambiguous < 2000);
}

TEST_CASE("iso cell hit agrees with the double reference for corners up to 1e4", "[ikd][cell]") {
    Stats s = random_run(7u, 20000, 1e4f);
    print_stats("[0, 1e4]", s);
    INFO("first failure: " << s.first_failure);
    CHECK(s.failures == 0);
    CHECK(s.max_err <= 2e-5);
    CHECK(s.hits > 6000);
    CHECK(s.misses > 6000);
    CHECK(s.ambiguous < 400);
}

TEST_CASE("iso cell hit: a linear ramp is crossed exactly in both directions", "[ikd][cell]") {
    vec4 lo(0.0f, 1.0f, 0.0f, 1.0f), hi(0.0f, 1.0f, 0.0f, 1.0f);  // rho = x
    float t = -1.0f;
    // Rising density, from inside and from outside the cell.
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f, 0.3f, 0.7f), vec3(1.0f, 0.0f, 0.0f), 0.0f, 1.0f, 0.5f, t));
    REQUIRE(t == 0.5f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(-2.0f, 0.3f, 0.7f), vec3(1.0f, 0.0f, 0.0f), 2.0f, 3.0f, 0.5f, t));
    REQUIRE(t == 2.5f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f, 0.3f, 0.7f), vec3(1.0f, 0.0f, 0.0f), 0.0f, 1.0f, 0.25f, t));
    REQUIRE(t == 0.25f);
    // Falling density (the ray runs against the gradient).
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(1.0f, 0.3f, 0.7f), vec3(-1.0f, 0.0f, 0.0f), 0.0f, 1.0f, 0.5f, t));
    REQUIRE(t == 0.5f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(1.0f, 0.3f, 0.7f), vec3(-1.0f, 0.0f, 0.0f), 0.0f, 1.0f, 0.75f, t));
    REQUIRE(t == 0.25f);
    // A falling field along a slanted ray: 1 - x crosses 0.5 at x = 0.5, t = 0.5 / 0.5.
    vec4 flo(1.0f, 0.0f, 1.0f, 0.0f), fhi(1.0f, 0.0f, 1.0f, 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(flo, fhi, vec3(0.0f, 0.0f, 0.0f), vec3(0.5f, 0.5f, 0.25f), 0.0f, 2.0f, 0.5f, t));
    REQUIRE(t == 1.0f);
    // A direction component of zero and a tiny direction (interval scaled accordingly).
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f, 0.5f, 0.5f), vec3(1e-20f, 0.0f, 0.0f), 0.0f, 1e20f, 0.5f, t));
    REQUIRE(std::abs(double(t) - 0.5e20) <= 1e-6 * 1e20);
    // The isovalue outside the ramp: no hit, t_hit = t1.
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f, 0.3f, 0.7f), vec3(1.0f, 0.0f, 0.0f), 0.0f, 1.0f, 1.5f, t));
    REQUIRE(t == 1.0f);
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f, 0.3f, 0.7f), vec3(1.0f, 0.0f, 0.0f), 0.0f, 0.4f, 0.5f, t));
}

TEST_CASE("iso cell hit: a quadratic touching the isovalue is a tangent hit within the tolerance", "[ikd][cell]") {
    vec4 lo(0.0f, 0.0f, 0.0f, 1.0f), hi(0.0f, 0.0f, 0.0f, 1.0f);  // rho = x y
    vec3 o(0.0f, 1.0f, 0.5f), d(1.0f, -1.0f, 0.0f);                // rho(t) = t (1 - t), max 1/4 at t = 1/2
    float t = -1.0f;
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 1.0f, 0.25f, t));
    REQUIRE(t == 0.5f);
    // Just above the maximum: within SYLVA_ISO_TOUCH_REL * max |c - iso| (4e-6 * 0.75) it still
    // touches at the extremum; beyond it the ray misses.
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 1.0f, 0.25f + 2e-6f, t));
    REQUIRE(std::abs(t - 0.5f) <= 1e-6f);
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 1.0f, 0.25f + 1e-5f, t));
    // Just below: two crossings, the first one is reported.
    float iso = 0.249f;
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 1.0f, iso, t));
    double expect = (1.0 - std::sqrt(1.0 - 4.0 * double(iso))) / 2.0;
    REQUIRE(std::abs(double(t) - expect) <= 1e-6);
    // The same from the other end of the chord, and the falling version 1 - x y at 3/4.
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(1.0f, 0.0f, 0.5f), -d, 0.0f, 1.0f, iso, t));
    REQUIRE(std::abs(double(t) - expect) <= 1e-6);
    vec4 flo(1.0f, 1.0f, 1.0f, 0.0f), fhi(1.0f, 1.0f, 1.0f, 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(flo, fhi, o, d, 0.0f, 1.0f, 0.75f, t));
    REQUIRE(t == 0.5f);
    REQUIRE(sh::sylva_iso_cell_hit(flo, fhi, o, d, 0.0f, 1.0f, 0.75f - 2e-6f, t));
    REQUIRE(std::abs(t - 0.5f) <= 1e-6f);
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(flo, fhi, o, d, 0.0f, 1.0f, 0.75f - 1e-5f, t));
    // A tangent point beyond t1 is no hit; t1 on it is (an end within the tolerance).
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 0.4f, 0.25f, t));
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 0.5f, 0.25f, t));
    REQUIRE(t == 0.5f);
}

TEST_CASE("iso cell hit: a double root before a simple root is found first", "[ikd][cell]") {
    // Along the diagonal p = (t, t, t): rho - iso = 48 (t - 1/4)^2 (t - 3/4), Bernstein
    // coefficients (-2.25, 4.75, -8.25, 6.75): touches zero at 1/4 from below, crosses at 3/4.
    const float iso = 0.5f;
    vec4 lo, hi;
    diagonal_cell(iso, vec4(-2.25f, 4.75f, -8.25f, 6.75f), lo, hi);
    Case c{lo, hi, vec3(0.0f), vec3(1.0f), 0.0f, 1.0f, iso};
    REQUIRE(std::abs(g_ref(c, 0.25)) == 0.0);
    REQUIRE(std::abs(g_ref(c, 0.75)) == 0.0);
    float t = -1.0f;
    REQUIRE(hit_of(c, t));
    REQUIRE(t == 0.25f);
    // Raised a little: the touch disappears, the crossing near 3/4 is next.
    c.iso = iso + 1e-3f;
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(double(t) - bisect(c, 0.6, 1.0)) <= 1e-6);
    // Lowered a little: two crossings around 1/4, the first one.
    c.iso = iso - 1e-3f;
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(double(t) - bisect(c, 0.0, 0.25)) <= 1e-6);
    // The mirrored ray meets the simple root (now at 1/4 along it) first.
    c.iso = iso;
    c.o = vec3(1.0f);
    c.d = vec3(-1.0f);
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(t - 0.25f) <= 1e-6f);
    // Starting past the double root on the forward ray: only the crossing at 3/4 remains.
    c.o = vec3(0.0f);
    c.d = vec3(1.0f);
    c.t0 = 0.3f;
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(t - 0.75f) <= 1e-6f);
}

TEST_CASE("iso cell hit: corners equal to the isovalue", "[ikd][cell]") {
    float t = -1.0f;
    // All eight: the whole cell is on the surface, the hit is at t0 (also for t0 == t1).
    REQUIRE(sh::sylva_iso_cell_hit(splat(0.3f), splat(0.3f), vec3(0.1f, 0.2f, 0.3f), vec3(0.3f, -0.2f, 0.1f), 0.25f,
                                   0.75f, 0.3f, t));
    REQUIRE(t == 0.25f);
    REQUIRE(sh::sylva_iso_cell_hit(splat(0.3f), splat(0.3f), vec3(0.5f), vec3(0.0f), 2.0f, 2.0f, 0.3f, t));
    REQUIRE(t == 2.0f);
    // One corner: a ray entering through it hits at entry, whatever the other corners.
    vec4 lo(0.5f, 1.0f, 0.9f, 0.7f), hi(0.8f, 0.6f, 1.0f, 0.95f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(-0.5f), vec3(1.0f, 1.0f, 1.0f), 0.5f, 1.5f, 0.5f, t));
    REQUIRE(t == 0.5f);
    // ... and a ray leaving through it (all else above iso) hits at exit.
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(1.0f), vec3(-1.0f, -1.0f, -1.0f), 0.0f, 1.0f, 0.5f, t));
    REQUIRE(t == 1.0f);
    // A ray through the cell that stays away from that corner misses.
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.5f, 0.5f, -1.0f), vec3(0.0f, 0.0f, 1.0f), 1.0f, 2.0f, 0.5f, t));
    // An edge on the surface (c000 = c100 = iso): a ray along it hits at t0.
    vec4 elo(0.5f, 0.5f, 0.9f, 0.1f), ehi(0.2f, 0.8f, 1.0f, 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(elo, ehi, vec3(-1.0f, 0.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f), 1.0f, 2.0f, 0.5f, t));
    REQUIRE(t == 1.0f);
}

TEST_CASE("iso cell hit: constant cells different from the isovalue never hit", "[ikd][cell]") {
    float t = 0.0f;
    vec3 o(0.2f, 0.4f, 0.6f), d(0.3f, 0.5f, -0.2f);
    for (float c : {0.0f, 0.3f, 1.0f, 1e4f, 1e-30f}) {
        for (float iso : {std::nextafter(c, 2e4f), std::nextafter(c, -1.0f), c + 0.5f, c * 0.5f - 0.25f}) {
            INFO("c " << c << " iso " << iso);
            REQUIRE_FALSE(sh::sylva_iso_cell_hit(splat(c), splat(c), o, d, 0.0f, 1.0f, iso, t));
            REQUIRE_FALSE(sh::sylva_iso_cell_hit(splat(c), splat(c), o, d, 0.5f, 0.5f, iso, t));
            REQUIRE_FALSE(sh::sylva_iso_cell_hit(splat(c), splat(c), o, vec3(0.0f), 0.0f, 1.0f, iso, t));
        }
    }
}

TEST_CASE("iso cell hit: a ray starting on the surface hits at t0", "[ikd][cell]") {
    vec4 lo(0.0f, 1.0f, 0.0f, 1.0f), hi(0.0f, 1.0f, 0.0f, 1.0f);  // rho = x
    float t = -1.0f;
    for (vec3 d : {vec3(1.0f, 0.2f, 0.1f), vec3(-1.0f, 0.2f, 0.1f), vec3(0.0f, 1.0f, 0.0f), vec3(0.0f)}) {
        INFO("d " << d.x << " " << d.y << " " << d.z);
        REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.5f, 0.1f, 0.2f), d, 0.0f, 0.4f, 0.5f, t));
        REQUIRE(t == 0.0f);
    }
    // Within the tolerance of the surface at t0 (4e-6 * 0.5 here) and moving away from it: t0;
    // farther away: no hit.
    vec3 o(0.5f, 0.1f, 0.2f), ex(1.0f, 0.0f, 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, -ex, 0.0f, 0.4f, 0.5f + 1e-6f, t));
    REQUIRE(t == 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, ex, 0.0f, 0.4f, 0.5f - 1e-6f, t));
    REQUIRE(t == 0.0f);
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, o, -ex, 0.0f, 0.4f, 0.5f + 1e-5f, t));
    // A curved field: rho = x y with the origin on x y = 1/4, leaving or entering the region.
    vec4 qlo(0.0f, 0.0f, 0.0f, 1.0f), qhi(0.0f, 0.0f, 0.0f, 1.0f);
    REQUIRE(sh::sylva_iso_cell_hit(qlo, qhi, vec3(0.5f, 0.5f, 0.5f), vec3(0.3f, -0.4f, 0.2f), 0.0f, 1.0f, 0.25f, t));
    REQUIRE(t == 0.0f);
    REQUIRE(sh::sylva_iso_cell_hit(qlo, qhi, vec3(0.5f, 0.5f, 0.5f), vec3(-0.3f, -0.4f, 0.2f), 0.0f, 1.0f, 0.25f, t));
    REQUIRE(t == 0.0f);
}

TEST_CASE("iso cell hit: grazing rays and zero-length intervals", "[ikd][cell]") {
    vec4 lo(0.0f, 1.0f, 0.3f, 0.9f), hi(0.2f, 0.6f, 0.5f, 1.0f);
    float t = -1.0f;
    // In the face y = 0, z = 0 (an edge): rho = x there.
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(-0.5f, 0.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f), 0.5f, 1.5f, 0.25f, t));
    REQUIRE(t == 0.75f);
    // In the face y = 0, slanted: rho = (1 - z) x + z (0.2 + 0.4 x), against the reference.
    Case c{lo, hi, vec3(0.0f, 0.0f, 0.2f), vec3(1.0f, 0.0f, 0.5f), 0.0f, 1.0f, 0.4f};
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(double(t) - bisect(c, 0.0, 1.0)) <= 1e-6);
    // Nearly tangent to the face: a direction component of 1e-7.
    c.d = vec3(1.0f, 1e-7f, 0.5f);
    REQUIRE(hit_of(c, t));
    REQUIRE(std::abs(double(t) - bisect(c, 0.0, 1.0)) <= 1e-6);
    // Zero-length intervals (the ray grazes an edge or corner): a hit only where rho = iso there.
    vec3 o(1.0f, 0.0f, 0.0f), d(0.0f, 0.7f, -0.7f);  // touches the cell at the corner (1, 0, 0)
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 0.0f, 1.0f, t));
    REQUIRE(t == 0.0f);
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 0.0f, 0.9f, t));
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, o, d, 0.0f, 0.0f, 1.0f - 1e-6f, t));  // within the tolerance
    REQUIRE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.5f, -1.0f, 1.0f), vec3(0.0f, 1.0f, -1.0f), 1.0f, 1.0f, 0.5f, t));
    REQUIRE(t == 1.0f);
    // An interval given backwards, or NaN, is empty.
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), 1.0f, 0.0f, 0.5f, t));
    float nan = std::numeric_limits<float>::quiet_NaN();
    REQUIRE_FALSE(sh::sylva_iso_cell_hit(lo, hi, vec3(0.0f), vec3(1.0f, 0.0f, 0.0f), nan, 1.0f, 0.5f, t));
}

TEST_CASE("iso cell hit: large and tiny corner magnitudes give the same hits", "[ikd][cell]") {
    std::mt19937 rng(99);
    int hits = 0;
    for (int n = 0; n < 2000; ++n) {
        Case c = random_case(rng, 1.0f);
        float t = 0.0f;
        bool hit = hit_of(c, t);
        hits += hit ? 1 : 0;
        // Powers of two: the header normalises by one, so the answer is bit for bit the same.
        for (float k : {0x1p-100f, 0x1p-60f, 0x1p40f, 0x1p100f}) {
            Case s = c;
            s.lo = c.lo * k;
            s.hi = c.hi * k;
            s.iso = c.iso * k;
            float ts = 0.0f;
            INFO(describe(c, hit, t, Ref{}) << " scaled by " << k);
            REQUIRE(hit_of(s, ts) == hit);
            REQUIRE(ts == t);
        }
        // 1e4 and 1e-20 round the corners: same hits where the reference calls them clean.
        Ref r = reference(c);
        for (float k : {1e4f, 1e-20f}) {
            Case s = c;
            s.lo = c.lo * k;
            s.hi = c.hi * k;
            s.iso = c.iso * k;
            float ts = 0.0f;
            bool hs = hit_of(s, ts);
            if (r.clean) {
                INFO(describe(s, hs, ts, r));
                REQUIRE(hs);
                REQUIRE(std::abs(double(ts) - double(t)) <= 2e-5 * std::max(1.0, double(c.t1 - c.t0)));
            }
        }
    }
    REQUIRE(hits > 200);
}
