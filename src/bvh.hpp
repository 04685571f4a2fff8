#pragma once

// BVH text of a motion on the model's skeleton: the hierarchy from the rest
// offsets, then one line per frame of root position and ZXY Euler angles in
// degrees (metres; opens in Blender). Written by ardy-generate and by the
// Godot node's export_bvh, from the same frames.

#include <string>
#include <vector>

#include "planner.hpp"
#include "skeleton.hpp"

namespace ardy {

std::string motion_to_bvh(const Skeleton& skeleton, double fps, const std::vector<Pose>& frames);

}  // namespace ardy
