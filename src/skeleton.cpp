#include "skeleton.hpp"

#include <cmath>
#include <unordered_map>
#include <utility>

namespace ardy {
namespace {

std::string joint_label(size_t joint, const std::vector<std::string>& names) {
  std::string label = "joint " + std::to_string(joint);
  if (joint < names.size() && !names[joint].empty()) label += " ('" + names[joint] + "')";
  return label;
}

}  // namespace

Skeleton::Skeleton(std::vector<std::string> names, std::vector<int> parents, std::vector<glm::vec3> offsets)
    : names_(std::move(names)), parents_(std::move(parents)), offsets_(std::move(offsets)) {
  if (names_.empty()) throw Error("skeleton: no joints");
  if (names_.size() > kMaxJoints) {
    throw Error("skeleton: " + std::to_string(names_.size()) + " joints, more than the " +
                std::to_string(kMaxJoints) + " supported");
  }
  if (parents_.size() != names_.size() || offsets_.size() != names_.size()) {
    throw Error("skeleton: " + std::to_string(names_.size()) + " joint names, " + std::to_string(parents_.size()) +
                " parents and " + std::to_string(offsets_.size()) + " offsets; expected one of each per joint");
  }
  std::unordered_map<std::string_view, size_t> seen;
  for (size_t j = 0; j < names_.size(); ++j) {
    if (names_[j].empty()) throw Error("skeleton: joint " + std::to_string(j) + " has an empty name");
    const auto [it, inserted] = seen.emplace(names_[j], j);
    if (!inserted) {
      throw Error("skeleton: joint name '" + names_[j] + "' appears twice (joints " + std::to_string(it->second) +
                  " and " + std::to_string(j) + ")");
    }
    const int p = parents_[j];
    if (j == 0) {
      if (p != -1) {
        throw Error("skeleton: " + joint_label(0, names_) + " must be the root (parent -1), found parent " +
                    std::to_string(p));
      }
    } else if (p < 0 || static_cast<size_t>(p) >= j) {
      throw Error("skeleton: " + joint_label(j, names_) + " has parent " + std::to_string(p) +
                  "; a parent must be an earlier joint (0.." + std::to_string(j - 1) +
                  "), and only joint 0 may be the root");
    }
    const glm::vec3& o = offsets_[j];
    if (!std::isfinite(o.x) || !std::isfinite(o.y) || !std::isfinite(o.z)) {
      throw Error("skeleton: the rest offset of " + joint_label(j, names_) + " is not finite");
    }
  }
}

void Skeleton::check_index(size_t joint) const {
  if (joint >= names_.size()) {
    throw Error("skeleton: joint index " + std::to_string(joint) + " out of range (the skeleton has " +
                std::to_string(names_.size()) + " joints)");
  }
}

const std::string& Skeleton::name(size_t joint) const {
  check_index(joint);
  return names_[joint];
}

int Skeleton::parent(size_t joint) const {
  check_index(joint);
  return parents_[joint];
}

const glm::vec3& Skeleton::offset(size_t joint) const {
  check_index(joint);
  return offsets_[joint];
}

std::vector<size_t> Skeleton::children(size_t joint) const {
  check_index(joint);
  std::vector<size_t> out;
  for (size_t j = joint + 1; j < parents_.size(); ++j) {
    if (parents_[j] == static_cast<int>(joint)) out.push_back(j);
  }
  return out;
}

std::optional<size_t> Skeleton::find(std::string_view name) const {
  for (size_t j = 0; j < names_.size(); ++j) {
    if (names_[j] == name) return j;
  }
  return std::nullopt;
}

size_t Skeleton::index_of(std::string_view name) const {
  if (const auto joint = find(name)) return *joint;
  std::string known;
  for (const std::string& n : names_) known += (known.empty() ? "" : ", ") + n;
  throw Error("skeleton: unknown joint '" + std::string(name) + "' (the skeleton's joints are " + known + ")");
}

std::vector<size_t> Skeleton::indices_of(const std::vector<std::string>& names) const {
  std::vector<size_t> out;
  out.reserve(names.size());
  for (const std::string& n : names) out.push_back(index_of(n));
  return out;
}

}  // namespace ardy
