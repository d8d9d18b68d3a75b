#version 460
// DVR with empty-space skipping (sylva/shared/kd_dvr.h): the kernel of
// sylva/shared/kd_dvr_main.glsl (bindings and specialization constants described there), with
// the library's transfer-function tables and no hooks.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/kd_dvr_main.glsl"
