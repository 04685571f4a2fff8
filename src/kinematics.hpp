#pragma once

// Rotation conversions and forward kinematics (GLM, float32, the model's
// precision). Conventions, shared with export_tools (data/rotations.py):
//
// - rotation matrices act on column vectors: v_world = R * v_local; GLM
//   matrices are column-major, R[c][r] is row r of column c;
// - 6D = the first two columns, column-major: (r00, r10, r20, r01, r11, r21);
//   back to a matrix by Gram-Schmidt, third column = first x second;
// - quaternions are glm::quat (constructed glm::quat(w, x, y, z)), unit,
//   and quat_from_matrix returns the one with w >= 0;
// - heading psi is a rotation about +Y, psi = 0 faces +Z, and
//   heading_rotation(psi) turns +Z towards +X.
//
// Per-skeleton functions take and fill std::vectors of joint_count entries
// (joint order of the Skeleton) and throw Error on a size mismatch; the
// output vectors are resized, so reusing them avoids allocations.

#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "skeleton.hpp"

namespace ardy {

// --- single rotations --------------------------------------------------------

// Rotation from 6 floats (r00, r10, r20, r01, r11, r21). Degenerate input (a
// zero first column, or parallel columns) falls back to a valid rotation
// instead of producing NaN.
glm::mat3 rotation_from_6d(const float* six);
// Writes the 6 floats of a rotation.
void rotation_to_6d(const glm::mat3& rotation, float* six);

glm::quat quat_from_matrix(const glm::mat3& rotation);  // unit, w >= 0
glm::mat3 matrix_from_quat(const glm::quat& q);         // q need not be unit

// Spherical interpolation along the shorter arc (t = 0 gives a, 1 gives b),
// falling back to normalized lerp when a and b are nearly equal.
glm::quat slerp_shortest(const glm::quat& a, const glm::quat& b, float t);
glm::mat3 slerp_rotation(const glm::mat3& a, const glm::mat3& b, float t);

// Rotation about +Y by psi (radians).
glm::mat3 heading_rotation(float psi);
// psi from the (cos psi, sin psi) pair the features store; need not be unit.
float heading_angle(float cos_psi, float sin_psi);

// Rotation by `angle` radians about the unit `axis` (right-handed).
glm::mat3 rotation_about(const glm::vec3& axis, float angle);
// The shortest rotation taking unit vector u onto unit vector v (a half turn
// about some axis perpendicular to u when they are opposite).
glm::mat3 rotation_between(const glm::vec3& u, const glm::vec3& v);

// Two-bone IK of a limb with joints a (hip), b (knee), c (ankle), world
// space: world-space rotations to premultiply onto the upper bone's world
// rotation (`upper`) and the lower bone's (`lower`) so that the ankle reaches
// `target` (or as close as the bone lengths allow, never fully straight), the
// bones keep their lengths and the knee keeps bending in the plane it bends
// in now; `bend_axis` (unit) is that plane's normal for a straight limb (for
// a leg: the character's left-to-right axis). `hinge`: the joint bends only
// to the front of `bend_axis` (a knee), so within kStraightBend of straight,
// or bent backward, it bends about `bend_axis` instead of its own plane.
struct TwoBoneRotations {
  glm::mat3 upper{1.0f};
  glm::mat3 lower{1.0f};
};
constexpr float kStraightBend = 0.1f;  // radians
TwoBoneRotations two_bone_ik(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const glm::vec3& target,
                             const glm::vec3& bend_axis, bool hinge = false);

// --- skeletons ---------------------------------------------------------------

// Parent-relative rotations -> world rotations (global[0] = local[0]).
void local_to_global(const Skeleton& skeleton, const std::vector<glm::mat3>& local, std::vector<glm::mat3>& global);
// World rotations -> parent-relative rotations (local[j] = global[parent]^T * global[j]).
void global_to_local(const Skeleton& skeleton, const std::vector<glm::mat3>& global, std::vector<glm::mat3>& local);

// World joint positions from world rotations and the root position:
// positions[0] = root_position, positions[j] = positions[parent] +
// global[parent] * offset[j].
void joint_positions(const Skeleton& skeleton, const glm::vec3& root_position, const std::vector<glm::mat3>& global,
                     std::vector<glm::vec3>& positions);

struct GlobalPose {
  std::vector<glm::mat3> rotations;  // world rotation per joint
  std::vector<glm::vec3> positions;  // world position per joint
};

// FK: local rotations + root position -> world rotations and positions.
void forward_kinematics(const Skeleton& skeleton, const glm::vec3& root_position,
                        const std::vector<glm::mat3>& local_rotations, GlobalPose& out);
GlobalPose forward_kinematics(const Skeleton& skeleton, const glm::vec3& root_position,
                              const std::vector<glm::mat3>& local_rotations);

// Per-joint interpolation of two poses of the same skeleton: rotations by
// slerp_rotation, positions linearly. Sizes must match (Error otherwise).
void interpolate_rotations(const std::vector<glm::mat3>& a, const std::vector<glm::mat3>& b, float t,
                           std::vector<glm::mat3>& out);
void interpolate_positions(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, float t,
                           std::vector<glm::vec3>& out);

}  // namespace ardy
