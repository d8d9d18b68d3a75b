// sylva/elements/rbf.hpp -- Gaussian radial basis functions truncated at a radius
// (Kinkelin section 4.2 and 7: "truncated Radial Basis Functions" as BIH elements).
#ifndef SYLVA_ELEMENTS_RBF_HPP
#define SYLVA_ELEMENTS_RBF_HPP

#include "sylva/elements/sphere.hpp"

namespace sylva::elements {

// GaussianRbf is defined once, in the shared subset (sylva/shared/sphere_element.h).
inline Sphere GaussianRbf::sphere() const { return sylva_rbf_sphere(*this); }
inline Aabb GaussianRbf::bounds() const { return sphere().bounds(); }
inline std::optional<Interval> GaussianRbf::intersect(const Ray& r, Interval i) const { return sphere().intersect(r, i); }
inline std::optional<Contribution> GaussianRbf::interact(const Ray& r, Interval i) const {
    return sphere().interact(r, i);
}
inline Sphere as_sphere(const GaussianRbf& g) { return g.sphere(); }

/// C++ side of the protocol: the record sylva_elem_load(GaussianRbf) reads.
inline void sylva_elem_store(const GaussianRbf& g, ::sylva::shared::RecordOut out) {
    out.v3(0u, g.center);
    out.f(3u, g.sigma);
    out.f(4u, g.truncation);
    out.u(5u, pack_rgba8(g.rgba));
}

}  // namespace sylva::elements

namespace sylva {
using elements::GaussianRbf;
}  // namespace sylva

#endif  // SYLVA_ELEMENTS_RBF_HPP
