#pragma once

// The joint hierarchy of a model: names, parents, rest offsets. Read from the
// model package, never hard-coded; validated once on construction, so code
// that holds a Skeleton can index it without checks.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "error.hpp"

namespace ardy {

class Skeleton {
 public:
  // Joint 0 is the root (parent -1); every other joint's parent comes before
  // it. Names are non-empty and unique. offsets[j] is joint j's rest position
  // in its parent's frame (metres; offsets[0] is not used by FK, the root sits
  // at the root position). Throws Error naming the offending joint.
  Skeleton(std::vector<std::string> names, std::vector<int> parents, std::vector<glm::vec3> offsets);

  static constexpr size_t kMaxJoints = 1024;

  size_t joint_count() const { return names_.size(); }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<int>& parents() const { return parents_; }
  const std::vector<glm::vec3>& offsets() const { return offsets_; }

  // Per-joint accessors; throw Error for an index out of range.
  const std::string& name(size_t joint) const;
  int parent(size_t joint) const;  // -1 for the root
  const glm::vec3& offset(size_t joint) const;
  std::vector<size_t> children(size_t joint) const;

  // Index of a joint by exact name.
  std::optional<size_t> find(std::string_view name) const;
  // As find, but an unknown name throws Error "skeleton: unknown joint
  // 'Hand' (the skeleton's joints are Hips, Spine, ...)".
  size_t index_of(std::string_view name) const;
  std::vector<size_t> indices_of(const std::vector<std::string>& names) const;

 private:
  void check_index(size_t joint) const;

  std::vector<std::string> names_;
  std::vector<int> parents_;
  std::vector<glm::vec3> offsets_;
};

}  // namespace ardy
