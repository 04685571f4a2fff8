#include "bvh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <glm/geometric.hpp>
#include "kinematics.hpp"

namespace ardy {

namespace {

// R = Rz(z) Rx(x) Ry(y): BVH channels "Zrotation Xrotation Yrotation" (degrees).
glm::vec3 euler_zxy_degrees(const glm::mat3& r) {
  const auto m = [&](int row, int col) { return double(r[col][row]); };
  constexpr double kDeg = 57.29577951308232;
  const double sx = std::clamp(m(2, 1), -1.0, 1.0);
  const double x = std::asin(sx);
  double z = 0.0, y = 0.0;
  if (std::fabs(sx) < 0.9999999) {
    z = std::atan2(-m(0, 1), m(1, 1));
    y = std::atan2(-m(2, 0), m(2, 2));
  } else {  // gimbal lock: put the whole turn into z
    z = std::atan2(m(1, 0), m(0, 0));
  }
  return glm::vec3(float(z * kDeg), float(x * kDeg), float(y * kDeg));
}

std::string fixed(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6f", std::fabs(v) < 5e-7 ? 0.0 : v);
  return buffer;
}

}  // namespace

std::string motion_to_bvh(const Skeleton& skeleton, double fps, const std::vector<Pose>& frames) {
  std::ostringstream out;
  out << "HIERARCHY\n";
  // Depth-first, children in joint order (parents come first, so joint 0 is the root).
  std::vector<size_t> order;
  const auto emit = [&](const auto& self, size_t j, int depth) -> void {
    const std::string pad(size_t(depth) * 2, ' ');
    const glm::vec3 o = j == 0 ? glm::vec3(0.0f) : skeleton.offset(j);
    out << pad << (j == 0 ? "ROOT " : "JOINT ") << skeleton.name(j) << "\n" << pad << "{\n";
    out << pad << "  OFFSET " << fixed(o.x) << " " << fixed(o.y) << " " << fixed(o.z) << "\n";
    if (j == 0) {
      out << pad << "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n";
    } else {
      out << pad << "  CHANNELS 3 Zrotation Xrotation Yrotation\n";
    }
    order.push_back(j);
    const std::vector<size_t> children = skeleton.children(j);
    for (size_t child : children) self(self, child, depth + 1);
    if (children.empty()) {
      // A short bone tip along the joint's own direction (Blender needs a tail).
      const float length = glm::length(o);
      const glm::vec3 tip = length > 1e-6f ? o * (std::max(0.05f, 0.5f * length) / length) : glm::vec3(0, 0.05f, 0);
      out << pad << "  End Site\n" << pad << "  {\n";
      out << pad << "    OFFSET " << fixed(tip.x) << " " << fixed(tip.y) << " " << fixed(tip.z) << "\n";
      out << pad << "  }\n";
    }
    out << pad << "}\n";
  };
  emit(emit, 0, 0);
  out << "MOTION\n";
  out << "Frames: " << frames.size() << "\n";
  char frame_time[64];
  std::snprintf(frame_time, sizeof frame_time, "%.8f", 1.0 / fps);
  out << "Frame Time: " << frame_time << "\n";
  for (const Pose& frame : frames) {
    const glm::vec3& root = frame.positions[0];
    std::string line = fixed(root.x) + " " + fixed(root.y) + " " + fixed(root.z);
    for (size_t j : order) {
      const glm::vec3 e = euler_zxy_degrees(matrix_from_quat(frame.local_rotations[j]));
      line += " " + fixed(e.x) + " " + fixed(e.y) + " " + fixed(e.z);
    }
    out << line << "\n";
  }
  return out.str();
}

}  // namespace ardy
