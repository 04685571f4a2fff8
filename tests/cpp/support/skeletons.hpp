#pragma once

// Test skeletons: the ARDY 21-joint hierarchy with made-up rest offsets, and
// a three-joint chain small enough to compute by hand.

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "skeleton.hpp"

namespace ardy_test {

inline ardy::Skeleton ardy_test_skeleton() {
  std::vector<std::string> names{"Hips",       "Spine",      "Chest",      "Neck",       "Head",
                                 "Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L",     "Shoulder_R",
                                 "UpperArm_R", "LowerArm_R", "Hand_R",     "UpperLeg_L", "LowerLeg_L",
                                 "Foot_L",     "Toes_L",     "UpperLeg_R", "LowerLeg_R", "Foot_R",
                                 "Toes_R"};
  std::vector<int> parents{-1, 0, 1, 2, 3, 2, 5, 6, 7, 2, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19};
  std::vector<glm::vec3> offsets{
      {0, 0, 0},       {0, 0.1f, 0},    {0, 0.2f, 0},     {0, 0.2f, 0},     {0, 0.1f, 0},      {0.05f, 0.15f, 0},
      {0.1f, 0, 0},    {0.25f, 0, 0},   {0.25f, 0, 0},    {-0.05f, 0.15f, 0}, {-0.1f, 0, 0},   {-0.25f, 0, 0},
      {-0.25f, 0, 0},  {0.1f, -0.05f, 0}, {0, -0.4f, 0},  {0, -0.4f, 0},    {0, -0.05f, 0.1f}, {-0.1f, -0.05f, 0},
      {0, -0.4f, 0},   {0, -0.4f, 0},   {0, -0.05f, 0.1f}};
  return ardy::Skeleton(std::move(names), std::move(parents), std::move(offsets));
}

// root -> a -> b, each bone 1 m along +Y.
inline ardy::Skeleton chain_skeleton() {
  return ardy::Skeleton({"root", "a", "b"}, {-1, 0, 1}, {{0, 0, 0}, {0, 1, 0}, {0, 1, 0}});
}

}  // namespace ardy_test
