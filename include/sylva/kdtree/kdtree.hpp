// sylva/kdtree/kdtree.hpp -- umbrella for the empty-space kd-trees (Vidal et al.; Zellmann et al.):
// occupancy and summed-volume tables, the serial, parallel and binned builders, the encoding,
// its validator, the shared iterator and the leaf / subvolume lists.
#ifndef SYLVA_KDTREE_KDTREE_HPP
#define SYLVA_KDTREE_KDTREE_HPP

#include "sylva/kdtree/build.hpp"
#include "sylva/kdtree/build_binned.hpp"
#include "sylva/kdtree/build_parallel.hpp"
#include "sylva/kdtree/encode.hpp"
#include "sylva/kdtree/local_boxes.hpp"
#include "sylva/kdtree/query.hpp"
#include "sylva/kdtree/subvolumes.hpp"
#include "sylva/kdtree/tree.hpp"
#include "sylva/kdtree/validate.hpp"
#include "sylva/volume/occupancy.hpp"
#include "sylva/volume/partial_svt.hpp"
#include "sylva/volume/svt.hpp"

#endif  // SYLVA_KDTREE_KDTREE_HPP
