// sylva/shared/kd_elem_particles.h -- the particle integrator of sylva/shared/particles.h over
// the element kd-tree (sylva/shared/kd_elem_iter.h): the one integrator of
// sylva/shared/index_particles.h with the kd-tree as its index (sylva/shared/element_kd.h), so
// the image equals the element octree's (octree_particles.h), bit for bit. Records: the 8-word
// particle records of particles.h in the element order the kd-tree was built over (element e is
// record e).
//
// In GLSL it defines SylvaIndexIter as SylvaKdElemIter unless the shader did (one index a shader).
#ifndef SYLVA_SHARED_KD_ELEM_PARTICLES_H
#define SYLVA_SHARED_KD_ELEM_PARTICLES_H

#include "sylva/shared/element_kd.h"
#ifndef __cplusplus
#ifndef SylvaIndexIter
#define SylvaIndexIter SylvaKdElemIter
#endif
#endif
#include "sylva/shared/index_particles.h"

SYLVA_BEGIN_NAMESPACE

/// Renders one ray through a particle element kd-tree (`records` 8-word records in `elems`, at
/// most SYLVA_PARTICLE_MAX_RECORDS): sylva_index_render_particles over it.
SYLVA_FN vec4 sylva_kde_render_particles(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint records, vec3 o,
                                         vec3 d, float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                         SYLVA_OUT(uint) status) {
    return sylva_index_render_particles SYLVA_INDEX_TARGS(SylvaKdElemIter)(
        SYLVA_PASS_BUF(words), word_count, SYLVA_PASS_BUF(elems), records, o, d, t_min, t_max, alpha_stop, steps,
        status);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_ELEM_PARTICLES_H
