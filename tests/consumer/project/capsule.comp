#version 460
// The library's generic element kernel (hits in order, first hit, front-to-back compositing)
// for the user's capsule: the five lines of sylva/shared/element_prologue.glsl, compiled by the
// installed sylva_add_spirv against the installed headers.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "capsule.h"
#define SylvaElem Capsule
#include "sylva/shared/element_main.glsl"
