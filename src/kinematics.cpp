#include "kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

namespace ardy {
namespace {

constexpr float kTiny = 1e-12f;

void check_size(const char* what, size_t found, size_t expected) {
  if (found != expected) {
    throw Error(std::string(what) + ": " + std::to_string(found) + " entries for a skeleton of " +
                std::to_string(expected) + " joints");
  }
}

// A unit vector orthogonal to `a` (unit): the cross product with the basis
// axis least aligned with it.
glm::vec3 any_orthogonal(const glm::vec3& a) {
  const glm::vec3 ax = glm::abs(a);
  const glm::vec3 axis = ax.x <= ax.y && ax.x <= ax.z ? glm::vec3(1, 0, 0)
                         : ax.y <= ax.z               ? glm::vec3(0, 1, 0)
                                                      : glm::vec3(0, 0, 1);
  return glm::normalize(glm::cross(a, axis));
}

}  // namespace

glm::mat3 rotation_from_6d(const float* six) {
  glm::vec3 a(six[0], six[1], six[2]);
  glm::vec3 b(six[3], six[4], six[5]);
  const float a_len = glm::length(a);
  const glm::vec3 c0 = a_len > kTiny ? a / a_len : glm::vec3(1, 0, 0);
  b -= glm::dot(c0, b) * c0;
  const float b_len = glm::length(b);
  const glm::vec3 c1 = b_len > kTiny ? b / b_len : any_orthogonal(c0);
  return glm::mat3(c0, c1, glm::cross(c0, c1));
}

void rotation_to_6d(const glm::mat3& r, float* six) {
  six[0] = r[0][0];
  six[1] = r[0][1];
  six[2] = r[0][2];
  six[3] = r[1][0];
  six[4] = r[1][1];
  six[5] = r[1][2];
}

glm::quat quat_from_matrix(const glm::mat3& r) {
  // m(row, col) in the usual notation.
  const auto m = [&](int row, int col) { return r[col][row]; };
  const float trace = m(0, 0) + m(1, 1) + m(2, 2);
  // Four candidate solutions; the one with the largest diagonal term is the
  // numerically best.
  const float d[4] = {1.0f + trace, 1.0f + m(0, 0) - m(1, 1) - m(2, 2), 1.0f - m(0, 0) + m(1, 1) - m(2, 2),
                      1.0f - m(0, 0) - m(1, 1) + m(2, 2)};
  const int best = static_cast<int>(std::max_element(d, d + 4) - d);
  glm::quat q(1, 0, 0, 0);
  switch (best) {
    case 0: q = glm::quat(d[0], m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1)); break;
    case 1: q = glm::quat(m(2, 1) - m(1, 2), d[1], m(0, 1) + m(1, 0), m(0, 2) + m(2, 0)); break;
    case 2: q = glm::quat(m(0, 2) - m(2, 0), m(0, 1) + m(1, 0), d[2], m(1, 2) + m(2, 1)); break;
    default: q = glm::quat(m(1, 0) - m(0, 1), m(0, 2) + m(2, 0), m(1, 2) + m(2, 1), d[3]); break;
  }
  q = glm::normalize(q);
  return q.w < 0.0f ? -q : q;
}

glm::mat3 matrix_from_quat(const glm::quat& q_in) {
  const float len = glm::length(q_in);
  const glm::quat q = len > kTiny ? q_in / len : glm::quat(1, 0, 0, 0);
  const float w = q.w, x = q.x, y = q.y, z = q.z;
  glm::mat3 r(1.0f);
  r[0][0] = 1 - 2 * (y * y + z * z);
  r[1][0] = 2 * (x * y - w * z);
  r[2][0] = 2 * (x * z + w * y);
  r[0][1] = 2 * (x * y + w * z);
  r[1][1] = 1 - 2 * (x * x + z * z);
  r[2][1] = 2 * (y * z - w * x);
  r[0][2] = 2 * (x * z - w * y);
  r[1][2] = 2 * (y * z + w * x);
  r[2][2] = 1 - 2 * (x * x + y * y);
  return r;
}

glm::quat slerp_shortest(const glm::quat& a, const glm::quat& b_in, float t) {
  float cos_theta = glm::dot(a, b_in);
  glm::quat b = b_in;
  if (cos_theta < 0.0f) {
    b = -b;
    cos_theta = -cos_theta;
  }
  cos_theta = std::min(cos_theta, 1.0f);
  const float theta = std::acos(cos_theta);
  const float sin_theta = std::sin(theta);
  float wa = 1.0f - t;
  float wb = t;
  if (sin_theta > 1e-6f) {
    wa = std::sin((1.0f - t) * theta) / sin_theta;
    wb = std::sin(t * theta) / sin_theta;
  }
  return glm::normalize(wa * a + wb * b);
}

glm::mat3 slerp_rotation(const glm::mat3& a, const glm::mat3& b, float t) {
  return matrix_from_quat(slerp_shortest(quat_from_matrix(a), quat_from_matrix(b), t));
}

glm::mat3 heading_rotation(float psi) {
  const float c = std::cos(psi);
  const float s = std::sin(psi);
  // Columns: R * (1,0,0) = (c, 0, -s); R * (0,0,1) = (s, 0, c).
  return glm::mat3(glm::vec3(c, 0, -s), glm::vec3(0, 1, 0), glm::vec3(s, 0, c));
}

float heading_angle(float cos_psi, float sin_psi) { return std::atan2(sin_psi, cos_psi); }

glm::mat3 rotation_about(const glm::vec3& axis, float angle) {
  // Rodrigues: R = I cos + (1 - cos) a a^T + sin [a]x (GLM matrices are column-major).
  const float c = std::cos(angle), s = std::sin(angle), t = 1.0f - c;
  const float x = axis.x, y = axis.y, z = axis.z;
  return glm::mat3(glm::vec3(t * x * x + c, t * x * y + s * z, t * x * z - s * y),
                   glm::vec3(t * x * y - s * z, t * y * y + c, t * y * z + s * x),
                   glm::vec3(t * x * z + s * y, t * y * z - s * x, t * z * z + c));
}

glm::mat3 rotation_between(const glm::vec3& u, const glm::vec3& v) {
  const glm::vec3 axis = glm::cross(u, v);
  const float sine = glm::length(axis), cosine = glm::dot(u, v);
  if (sine > 1e-7f) return rotation_about(axis / sine, std::atan2(sine, cosine));
  if (cosine > 0.0f) return glm::mat3(1.0f);
  // Opposite: a half turn about any axis perpendicular to u.
  const glm::vec3 other = std::abs(u.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return rotation_about(glm::normalize(glm::cross(u, other)), 3.14159265358979f);
}

TwoBoneRotations two_bone_ik(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const glm::vec3& target,
                             const glm::vec3& bend_axis, bool hinge) {
  const float upper = glm::length(b - a), lower = glm::length(c - b);
  if (upper < 1e-6f || lower < 1e-6f) return {};
  // Never quite straight (the knee's plane would be lost) nor folded.
  const float reach = std::clamp(glm::length(target - a), std::abs(upper - lower) + 1e-4f, 0.999f * (upper + lower));
  const glm::vec3 upper_direction = (b - a) / upper, lower_direction = (c - b) / lower;
  const glm::vec3 own_normal = glm::cross(upper_direction, lower_direction);
  const float bend = glm::length(own_normal);
  glm::vec3 normal = bend > 1e-4f ? own_normal / bend : bend_axis;
  if (hinge) {
    // Near straight the knee's own plane is noise (a knee a degree past
    // straight flips it): within kStraightBend it turns toward `bend_axis`
    // made perpendicular to the upper bone, all the way for a straight or
    // backward-bent knee.
    glm::vec3 axis_normal = bend_axis - glm::dot(bend_axis, upper_direction) * upper_direction;
    axis_normal = glm::length(axis_normal) > 1e-4f ? glm::normalize(axis_normal) : bend_axis;
    const bool forward = glm::dot(own_normal, axis_normal) > 0.0f;
    const float own_weight = forward ? std::min(1.0f, bend / std::sin(kStraightBend)) : 0.0f;
    normal = own_weight * normal + (1.0f - own_weight) * axis_normal;
    normal = glm::length(normal) > 1e-6f ? glm::normalize(normal) : axis_normal;
  }
  // The knee's interior angle on the front of that plane now and for `reach`
  // (law of cosines; past straight it is over 180 degrees); turning the lower
  // bone by +phi about `normal` closes the angle by phi.
  const float now = glm::pi<float>() - std::atan2(glm::dot(own_normal, normal), glm::dot(upper_direction, lower_direction));
  const float wanted =
      std::acos(std::clamp((upper * upper + lower * lower - reach * reach) / (2.0f * upper * lower), -1.0f, 1.0f));
  const glm::mat3 knee = rotation_about(normal, now - wanted);
  const glm::vec3 ankle = b + knee * (c - b);
  const glm::vec3 to_target = target - a;
  if (glm::length(to_target) < 1e-6f) return {glm::mat3(1.0f), knee};
  const glm::mat3 swing = rotation_between(glm::normalize(ankle - a), glm::normalize(to_target));
  return {swing, swing * knee};
}

void local_to_global(const Skeleton& skeleton, const std::vector<glm::mat3>& local, std::vector<glm::mat3>& global) {
  const size_t n = skeleton.joint_count();
  check_size("local_to_global: local rotations", local.size(), n);
  global.resize(n);
  global[0] = local[0];
  const std::vector<int>& parents = skeleton.parents();
  for (size_t j = 1; j < n; ++j) global[j] = global[static_cast<size_t>(parents[j])] * local[j];
}

void global_to_local(const Skeleton& skeleton, const std::vector<glm::mat3>& global, std::vector<glm::mat3>& local) {
  const size_t n = skeleton.joint_count();
  check_size("global_to_local: global rotations", global.size(), n);
  local.resize(n);
  local[0] = global[0];
  const std::vector<int>& parents = skeleton.parents();
  for (size_t j = 1; j < n; ++j) local[j] = glm::transpose(global[static_cast<size_t>(parents[j])]) * global[j];
}

void joint_positions(const Skeleton& skeleton, const glm::vec3& root_position, const std::vector<glm::mat3>& global,
                     std::vector<glm::vec3>& positions) {
  const size_t n = skeleton.joint_count();
  check_size("joint_positions: global rotations", global.size(), n);
  positions.resize(n);
  positions[0] = root_position;
  const std::vector<int>& parents = skeleton.parents();
  const std::vector<glm::vec3>& offsets = skeleton.offsets();
  for (size_t j = 1; j < n; ++j) {
    const auto p = static_cast<size_t>(parents[j]);
    positions[j] = positions[p] + global[p] * offsets[j];
  }
}

void forward_kinematics(const Skeleton& skeleton, const glm::vec3& root_position,
                        const std::vector<glm::mat3>& local_rotations, GlobalPose& out) {
  check_size("forward_kinematics: local rotations", local_rotations.size(), skeleton.joint_count());
  local_to_global(skeleton, local_rotations, out.rotations);
  joint_positions(skeleton, root_position, out.rotations, out.positions);
}

GlobalPose forward_kinematics(const Skeleton& skeleton, const glm::vec3& root_position,
                              const std::vector<glm::mat3>& local_rotations) {
  GlobalPose out;
  forward_kinematics(skeleton, root_position, local_rotations, out);
  return out;
}

void interpolate_rotations(const std::vector<glm::mat3>& a, const std::vector<glm::mat3>& b, float t,
                           std::vector<glm::mat3>& out) {
  if (a.size() != b.size()) {
    throw Error("interpolate_rotations: " + std::to_string(a.size()) + " and " + std::to_string(b.size()) +
                " rotations; expected the same count");
  }
  out.resize(a.size());
  for (size_t j = 0; j < a.size(); ++j) out[j] = slerp_rotation(a[j], b[j], t);
}

void interpolate_positions(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, float t,
                           std::vector<glm::vec3>& out) {
  if (a.size() != b.size()) {
    throw Error("interpolate_positions: " + std::to_string(a.size()) + " and " + std::to_string(b.size()) +
                " positions; expected the same count");
  }
  out.resize(a.size());
  for (size_t j = 0; j < a.size(); ++j) out[j] = a[j] + t * (b[j] - a[j]);
}

}  // namespace ardy
