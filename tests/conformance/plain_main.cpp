// The conformance kit from a plain main, as a user without a test framework runs it: an
// ellipsoid (a unit ball scaled per axis), a user element, checked on the host; the exit status
// says whether it conforms, the report says why not.
#include <sylva/testing/conformance.hpp>

#include <cmath>
#include <iostream>
#include <optional>

namespace {

/// A user element: the ellipsoid with centre c and semi-axes s (per-axis scaled unit ball).
struct Ellipsoid {
    sylva::vec3 c{0.0f};
    sylva::vec3 s{1.0f};

    [[nodiscard]] sylva::Aabb bounds() const { return {c - s, c + s}; }
    /// The closest-approach form (as sylva::Sphere): the textbook discriminant b^2 - a q cancels
    /// near tangency and reported grazing hits up to 2.3e-4 outside bounds(), which the kit's
    /// BIH check found on an axis-parallel ray; the distance at the closest approach does not.
    [[nodiscard]] std::optional<sylva::Interval> intersect(const sylva::Ray& ray, sylva::Interval range) const {
        const sylva::vec3 o = (ray.origin - c) / s;
        const sylva::vec3 d = ray.direction / s;
        const float a = glm::dot(d, d);
        if (!(a > 0.0f)) return std::nullopt;
        const float tc = -glm::dot(o, d) / a;
        const sylva::vec3 p = o + tc * d;
        const float q = glm::dot(p, p);
        if (!(q <= 1.0f)) return std::nullopt;
        const float half = std::sqrt((1.0f - q) / a);
        const sylva::Interval t{std::max(range.t0, tc - half), std::min(range.t1, tc + half)};
        if (t.empty()) return std::nullopt;
        return t;
    }
};

}  // namespace

int main() {
    const sylva::testing::Report report = sylva::testing::check_element_type<Ellipsoid>([](sylva::testing::Rng& rng) {
        return Ellipsoid{rng.in_box({sylva::vec3(0.0f), sylva::vec3(10.0f)}),
                         sylva::vec3(rng.uniform(0.05f, 0.4f), rng.uniform(0.05f, 0.4f), rng.uniform(0.05f, 0.4f))};
    });
    std::cout << report;
    return report.ok() ? 0 : 1;
}
