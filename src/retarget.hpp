#pragma once

// Retargeting the model's motion onto any humanoid rig (design.md section 7).
// Engine-free: the Godot node describes its Skeleton3D as a list of RigBones
// and writes the RigPose it gets back.
//
// Mapping. Each model joint finds its rig bone by, in order: an explicit
// name (a BoneMap), the model's own name, the SkeletonProfileHumanoid name
// (Godot's importer output), the common Mixamo-style name, each compared
// without case and without a "prefix:" or "prefix_" (mixamorig:Hips).
//
// Transfer. Global rotations are transferred relative to each rig's rest
// pose: the model's rest pose has identity global rotations, a rig's has its
// own (A-pose, T-pose, bones with arbitrary rest rotations). For each mapped
// bone an alignment rotation A takes the rig's rest bone direction (to the
// bone of its first mapped child) onto the model's; bones with two mapped
// children (hips: spine and left leg; chest: neck and left shoulder) align a
// whole frame, so twist and facing agree too; leaf bones (head, hands, toes)
// take their parent's alignment. In pose: rig_global = F * model_global * A *
// rig_rest_global, with F the rotation from the model's world into skeleton
// space. Bone directions of the rig then agree with the model's; nothing
// flips or twists beyond the model's own rotation. Unmapped rig bones between
// mapped ones (and above the hips) keep their rest rotation; bones below the
// leaves (fingers) are not written.

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>

#include "skeleton.hpp"

namespace ardy {

// One bone of a rig, rest transform local to its parent bone (skeleton space
// for a bone without parent). Scale is not retargeted.
struct RigBone {
  std::string name;
  int parent = -1;
  glm::vec3 rest_position{0.0f};
  glm::quat rest_rotation{1.0f, 0.0f, 0.0f, 0.0f};
};

// The SkeletonProfileHumanoid name of a model joint ("Hand_L" -> "LeftHand"),
// or "" when the joint has none.
std::string humanoid_profile_name(std::string_view model_joint);

// The rig bone of each model joint (-1: unmapped). explicit_names maps model
// joint names to rig bone names and wins over every rule; an explicit name
// that the rig lacks leaves the joint unmapped. A rig bone is used once.
std::vector<int> match_bones(const Skeleton& model, const std::vector<RigBone>& rig,
                             const std::map<std::string, std::string>& explicit_names = {});

// What to write into the rig for one pose.
struct RigPose {
  std::vector<glm::quat> local_rotations;  // [bones] pose rotation of every bone, local to its parent
  std::vector<bool> written;               // [bones] whether the bone is driven (else left as it is)
  glm::vec3 root_position{0.0f};           // the root (hips) bone's pose position, local to its parent
  // Scratch of apply(), kept so a reused RigPose never allocates.
  std::vector<glm::quat> model_global;
  std::vector<glm::quat> rig_global;
};

class Retargeter {
 public:
  // bone_of_joint: match_bones' result (same length as the model's joints).
  // Error when the root joint (the hips) is unmapped, or a rig parent index
  // is out of range or forms a cycle.
  Retargeter(const Skeleton& model, std::vector<RigBone> rig, std::vector<int> bone_of_joint);

  size_t bone_count() const { return rig_.size(); }
  const std::vector<int>& bone_of_joint() const { return bone_of_joint_; }
  int root_bone() const { return bone_of_joint_[0]; }
  // Model joints without a rig bone, by name.
  std::vector<std::string> unmapped_joints() const;
  // Leg length (upper leg + lower leg, the mean of the mapped legs) of the
  // model and of the rig (skeleton units); 0 when a leg is not mapped.
  float model_leg_length() const { return model_leg_length_; }
  float rig_leg_length() const { return rig_leg_length_; }
  // The rig's rest global rotation and position of a bone (skeleton space).
  const glm::quat& rest_global_rotation(size_t bone) const { return rest_global_rotation_[bone]; }
  const glm::vec3& rest_global_position(size_t bone) const { return rest_global_position_[bone]; }

  // model_local: the model's local rotations (root: world), one per joint.
  // frame: rotation from the model's world into skeleton space.
  // root_position: where the root bone goes, skeleton space.
  // Allocates only the first time `out` is used.
  void apply(const std::vector<glm::quat>& model_local, const glm::quat& frame, const glm::vec3& root_position,
             RigPose& out) const;

  // The inverse of apply's transfer for one mapped bone: the model global
  // rotation (model world) that shows as `rig_global` (skeleton space).
  glm::quat model_global_rotation(size_t bone, const glm::quat& rig_global, const glm::quat& frame) const;
  // The model's local rotations that show as the rig pose `rig_local` (one
  // rotation per bone, local to its parent); unmapped joints follow their
  // parent (identity local rotation).
  std::vector<glm::quat> capture(const std::vector<glm::quat>& rig_local, const glm::quat& frame) const;

 private:
  const Skeleton& model_;
  std::vector<RigBone> rig_;
  std::vector<int> bone_of_joint_;
  std::vector<int> joint_of_bone_;       // [bones] model joint or -1
  std::vector<size_t> order_;            // rig bones, parents first
  std::vector<bool> written_;            // [bones]
  std::vector<glm::quat> alignment_;     // [bones] A (mapped bones)
  std::vector<glm::quat> rest_global_rotation_;
  std::vector<glm::vec3> rest_global_position_;
  float model_leg_length_ = 0.0f;
  float rig_leg_length_ = 0.0f;
};

}  // namespace ardy
