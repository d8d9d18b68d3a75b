// The analytic transfer function of issue 17, alpha = clamp((d - 0.1) / 0.9, 0, 1) 0.4, in the
// shared C++/GLSL subset: one text is the host's TfKind::Hook (the test calls
// sylva::shared::sylva_tf_user from VolumeRenderParams::tf_hook) and the GLSL hook of
// dvr_analytic_tf.comp (sylva/shared/tf.h, SYLVA_TF_USER).
#ifndef SYLVA_TESTS_ANALYTIC_TF_H
#define SYLVA_TESTS_ANALYTIC_TF_H

#include "sylva/shared/lang.h"

SYLVA_BEGIN_NAMESPACE

SYLVA_FN vec4 sylva_tf_user(float d) {
    SYLVA_PRECISE float x = (d - 0.1f) / 0.9f;
    float c = (x > 1.0f) ? 1.0f : ((x > 0.0f) ? x : 0.0f);  // clamp to [0, 1], NaN to 0
    SYLVA_PRECISE float a = c * 0.4f;
    return vec4(1.0f, 0.8f, 0.6f, a);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_TESTS_ANALYTIC_TF_H
