#version 460
// The generic element kernel (sylva/shared/element_main.glsl) for the library's Sphere over
// the element octree (element_octree.h): sylva::vk::ElementKernel with a vk::DeviceElementIndex
// (sylva-render --order exact --index octree --backend vulkan).
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "sylva/shared/sphere_element.h"
#include "sylva/shared/element_octree.h"
#define SylvaElem Sphere
#define SylvaIndexIter SylvaOctElemIter
#include "sylva/shared/element_main.glsl"
