#version 460
// The generic element kernel for demo::Capsule (capsule.h): hits in order and images.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "capsule.h"
#define SylvaElem Capsule
#include "sylva/shared/element_main.glsl"
