#version 460
// BIH-based volume rendering (sylva/shared/bih_dvr.h): the kernel of
// sylva/shared/bih_dvr_main.glsl (bindings and specialization constants described there), with
// the library's transfer-function tables and no hooks.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/bih_dvr_main.glsl"
