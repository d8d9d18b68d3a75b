// sylva/elements/rbf.hpp -- Gaussian radial basis functions truncated at a radius
// (Kinkelin section 4.2 and 7: "truncated Radial Basis Functions" as BIH elements).
#ifndef SYLVA_ELEMENTS_RBF_HPP
#define SYLVA_ELEMENTS_RBF_HPP

#include "sylva/elements/sphere.hpp"

namespace sylva {

/// exp(-d^2 / (2 sigma^2)) for d <= truncation * sigma, zero beyond.
struct GaussianRbf {
    vec3 center{0.0f};
    float sigma = 1.0f;
    float truncation = 3.0f;  ///< support radius in units of sigma
    vec4 rgba{1.0f};

    /// The same function written as a sphere: radius k sigma, kappa k^2 / 2.
    [[nodiscard]] Sphere sphere() const {
        return Sphere{center, truncation * sigma, rgba, 0.5f * truncation * truncation};
    }
    [[nodiscard]] Aabb bounds() const { return sphere().bounds(); }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& r, Interval i) const { return sphere().intersect(r, i); }
    [[nodiscard]] std::optional<Contribution> interact(const Ray& r, Interval i) const {
        return sphere().interact(r, i);
    }
};
inline Sphere as_sphere(const GaussianRbf& g) { return g.sphere(); }

}  // namespace sylva

#endif  // SYLVA_ELEMENTS_RBF_HPP
