#version 460
// The library's octree kernel (sylva/shared/octree_dvr_main.glsl) with the analytic transfer
// function of analytic_tf.h as its GLSL hook and no TF table: what a renderer author writes.
#extension GL_GOOGLE_include_directive : require
#define SYLVA_TF_USER
#define SYLVA_NO_TF
#include "sylva/shared/octree_dvr_main.glsl"
#include "analytic_tf.h"
