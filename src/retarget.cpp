#include "retarget.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "error.hpp"
#include "kinematics.hpp"

namespace ardy {

namespace {

struct NameRow {
  const char* model;
  const char* humanoid;  // SkeletonProfileHumanoid
  const char* mixamo;    // Mixamo-style rigs (usually prefixed "mixamorig:")
};

// The model's joints (design.md section 4) and their names in the two
// conventions a Godot user meets most. Mixamo's chest is Spine2 (the parent
// of neck and shoulders); its Spine1 keeps its rest, as UpperChest does.
constexpr NameRow kNameTable[] = {
    {"Hips", "Hips", "Hips"},
    {"Spine", "Spine", "Spine"},
    {"Chest", "Chest", "Spine2"},
    {"Neck", "Neck", "Neck"},
    {"Head", "Head", "Head"},
    {"Shoulder_L", "LeftShoulder", "LeftShoulder"},
    {"UpperArm_L", "LeftUpperArm", "LeftArm"},
    {"LowerArm_L", "LeftLowerArm", "LeftForeArm"},
    {"Hand_L", "LeftHand", "LeftHand"},
    {"Shoulder_R", "RightShoulder", "RightShoulder"},
    {"UpperArm_R", "RightUpperArm", "RightArm"},
    {"LowerArm_R", "RightLowerArm", "RightForeArm"},
    {"Hand_R", "RightHand", "RightHand"},
    {"UpperLeg_L", "LeftUpperLeg", "LeftUpLeg"},
    {"LowerLeg_L", "LeftLowerLeg", "LeftLeg"},
    {"Foot_L", "LeftFoot", "LeftFoot"},
    {"Toes_L", "LeftToes", "LeftToeBase"},
    {"UpperLeg_R", "RightUpperLeg", "RightUpLeg"},
    {"LowerLeg_R", "RightLowerLeg", "RightLeg"},
    {"Foot_R", "RightFoot", "RightFoot"},
    {"Toes_R", "RightToes", "RightToeBase"},
};

const NameRow* name_row(std::string_view model_joint) {
  for (const NameRow& row : kNameTable) {
    if (model_joint == row.model) return &row;
  }
  return nullptr;
}

// Lower case, without a "prefix:" and without separators, so "mixamorig:LeftArm",
// "leftarm" and "Left_Arm" compare equal.
std::string normalized(std::string_view name) {
  const size_t colon = name.find_last_of(':');
  if (colon != std::string_view::npos) name.remove_prefix(colon + 1);
  std::string out;
  out.reserve(name.size());
  for (char c : name) {
    if (c == '_' || c == '.' || c == ' ' || c == '-') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  constexpr std::string_view kMixamoPrefix = "mixamorig";
  if (out.size() > kMixamoPrefix.size() && out.compare(0, kMixamoPrefix.size(), kMixamoPrefix) == 0) {
    out.erase(0, kMixamoPrefix.size());
  }
  return out;
}

glm::quat quat_between(const glm::vec3& from, const glm::vec3& to) {
  return quat_from_matrix(rotation_between(glm::normalize(from), glm::normalize(to)));
}

// Orthonormal frame whose first axis is `primary` and whose plane holds `secondary`.
glm::mat3 frame_of(const glm::vec3& primary, const glm::vec3& secondary) {
  const glm::vec3 e1 = glm::normalize(primary);
  const glm::vec3 e3 = glm::normalize(glm::cross(primary, secondary));
  return glm::mat3(e1, glm::cross(e3, e1), e3);
}

constexpr float kMinLength = 1e-6f;

bool parallel(const glm::vec3& a, const glm::vec3& b) {
  const float la = glm::length(a), lb = glm::length(b);
  return la < kMinLength || lb < kMinLength || glm::length(glm::cross(a, b)) < 1e-3f * la * lb;
}

}  // namespace

std::string humanoid_profile_name(std::string_view model_joint) {
  const NameRow* row = name_row(model_joint);
  return row != nullptr ? row->humanoid : "";
}

std::vector<int> match_bones(const Skeleton& model, const std::vector<RigBone>& rig,
                             const std::map<std::string, std::string>& explicit_names) {
  std::map<std::string, int> rig_by_name;  // normalized -> first bone with it
  std::map<std::string, int> rig_by_exact_name;
  for (size_t bone = 0; bone < rig.size(); ++bone) {
    rig_by_name.emplace(normalized(rig[bone].name), static_cast<int>(bone));
    rig_by_exact_name.emplace(rig[bone].name, static_cast<int>(bone));
  }
  std::vector<int> result(model.joint_count(), -1);
  std::vector<bool> used(rig.size(), false);
  const auto take = [&](size_t joint, int bone) {
    if (bone < 0 || used[static_cast<size_t>(bone)]) return false;
    used[static_cast<size_t>(bone)] = true;
    result[joint] = bone;
    return true;
  };
  // Explicit names first, so the rules below cannot take their bones.
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    const auto found = explicit_names.find(model.name(joint));
    if (found == explicit_names.end()) continue;
    const auto bone = rig_by_exact_name.find(found->second);
    if (bone != rig_by_exact_name.end()) take(joint, bone->second);
  }
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    if (result[joint] >= 0 || explicit_names.count(model.name(joint)) > 0) continue;
    std::vector<std::string> candidates{model.name(joint)};
    if (const NameRow* row = name_row(model.name(joint))) {
      candidates.emplace_back(row->humanoid);
      candidates.emplace_back(row->mixamo);
    }
    for (const std::string& candidate : candidates) {
      const auto bone = rig_by_name.find(normalized(candidate));
      if (bone != rig_by_name.end() && take(joint, bone->second)) break;
    }
  }
  return result;
}

Retargeter::Retargeter(const Skeleton& model, std::vector<RigBone> rig, std::vector<int> bone_of_joint)
    : model_(model), rig_(std::move(rig)), bone_of_joint_(std::move(bone_of_joint)) {
  const size_t bones = rig_.size();
  if (bone_of_joint_.size() != model_.joint_count()) {
    throw Error("retarget: " + std::to_string(bone_of_joint_.size()) + " bone indices for " +
                std::to_string(model_.joint_count()) + " model joints");
  }
  joint_of_bone_.assign(bones, -1);
  for (size_t joint = 0; joint < bone_of_joint_.size(); ++joint) {
    const int bone = bone_of_joint_[joint];
    if (bone < -1 || bone >= static_cast<int>(bones)) {
      throw Error("retarget: joint '" + model_.name(joint) + "' maps to bone " + std::to_string(bone) + " of " +
                  std::to_string(bones));
    }
    if (bone >= 0) joint_of_bone_[static_cast<size_t>(bone)] = static_cast<int>(joint);
  }
  if (bone_of_joint_[0] < 0) {
    throw Error("retarget: the model's root joint '" + model_.name(0) + "' has no bone in the rig");
  }

  // Parents first (a Skeleton3D need not list them first).
  std::vector<int> state(bones, 0);  // 0 new, 1 visiting, 2 done
  order_.reserve(bones);
  for (size_t start = 0; start < bones; ++start) {
    std::vector<size_t> chain;
    for (int bone = static_cast<int>(start); bone >= 0 && state[static_cast<size_t>(bone)] != 2;
         bone = rig_[static_cast<size_t>(bone)].parent) {
      if (bone >= static_cast<int>(bones)) throw Error("retarget: bone parent index out of range");
      if (state[static_cast<size_t>(bone)] == 1) throw Error("retarget: the rig's bone parents form a cycle");
      state[static_cast<size_t>(bone)] = 1;
      chain.push_back(static_cast<size_t>(bone));
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      state[*it] = 2;
      order_.push_back(*it);
    }
  }

  rest_global_rotation_.resize(bones);
  rest_global_position_.resize(bones);
  for (size_t bone : order_) {
    const RigBone& b = rig_[bone];
    if (b.parent < 0) {
      rest_global_rotation_[bone] = glm::normalize(b.rest_rotation);
      rest_global_position_[bone] = b.rest_position;
    } else {
      const size_t parent = static_cast<size_t>(b.parent);
      rest_global_rotation_[bone] = glm::normalize(rest_global_rotation_[parent] * b.rest_rotation);
      rest_global_position_[bone] = rest_global_position_[parent] + rest_global_rotation_[parent] * b.rest_position;
    }
  }

  // Driven bones: mapped ones and every bone above a mapped one.
  written_.assign(bones, false);
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
    if (joint_of_bone_[*it] >= 0) written_[*it] = true;
    if (written_[*it] && rig_[*it].parent >= 0) written_[static_cast<size_t>(rig_[*it].parent)] = true;
  }

  // Alignments, model joints in order (parents first), so leaves can take their parent's.
  alignment_.assign(bones, glm::quat(1.0f, 0.0f, 0.0f, 0.0f));
  for (size_t joint = 0; joint < model_.joint_count(); ++joint) {
    const int bone = bone_of_joint_[joint];
    if (bone < 0) continue;
    std::vector<std::pair<glm::vec3, glm::vec3>> directions;  // (model, rig) to mapped children
    for (size_t child : model_.children(joint)) {
      const int child_bone = bone_of_joint_[child];
      if (child_bone < 0) continue;
      const glm::vec3 model_direction = model_.offset(child);
      const glm::vec3 rig_direction =
          rest_global_position_[static_cast<size_t>(child_bone)] - rest_global_position_[static_cast<size_t>(bone)];
      if (glm::length(model_direction) < kMinLength || glm::length(rig_direction) < kMinLength) continue;
      directions.emplace_back(model_direction, rig_direction);
    }
    glm::quat alignment(1.0f, 0.0f, 0.0f, 0.0f);
    if (directions.empty()) {
      const int parent = model_.parent(joint);
      if (parent >= 0 && bone_of_joint_[static_cast<size_t>(parent)] >= 0) {
        alignment = alignment_[static_cast<size_t>(bone_of_joint_[static_cast<size_t>(parent)])];
      }
    } else {
      const auto& [model_first, rig_first] = directions.front();
      alignment = quat_between(rig_first, model_first);
      for (size_t i = 1; i < directions.size(); ++i) {
        const auto& [model_second, rig_second] = directions[i];
        if (parallel(model_first, model_second) || parallel(rig_first, rig_second)) continue;
        const glm::mat3 model_frame = frame_of(model_first, model_second);
        const glm::mat3 rig_frame = frame_of(rig_first, rig_second);
        alignment = quat_from_matrix(model_frame * glm::transpose(rig_frame));
        break;
      }
    }
    alignment_[static_cast<size_t>(bone)] = glm::normalize(alignment);
  }

  // Leg lengths: upper + lower leg of each leg mapped in both skeletons.
  float model_sum = 0.0f, rig_sum = 0.0f;
  int legs = 0;
  for (const char* side : {"Left", "Right"}) {
    size_t joints[3];
    bool found = true;
    int index = 0;
    for (const char* part : {"UpperLeg", "LowerLeg", "Foot"}) {
      const std::string profile = std::string(side) + part;
      bool part_found = false;
      for (size_t joint = 0; joint < model_.joint_count(); ++joint) {
        if (humanoid_profile_name(model_.name(joint)) == profile && bone_of_joint_[joint] >= 0) {
          joints[index] = joint;
          part_found = true;
          break;
        }
      }
      found = found && part_found;
      ++index;
    }
    if (!found || model_.parent(joints[1]) != static_cast<int>(joints[0]) ||
        model_.parent(joints[2]) != static_cast<int>(joints[1])) {
      continue;
    }
    model_sum += glm::length(model_.offset(joints[1])) + glm::length(model_.offset(joints[2]));
    const auto rig_position = [&](size_t joint) {
      return rest_global_position_[static_cast<size_t>(bone_of_joint_[joint])];
    };
    rig_sum += glm::length(rig_position(joints[1]) - rig_position(joints[0])) +
               glm::length(rig_position(joints[2]) - rig_position(joints[1]));
    ++legs;
  }
  if (legs > 0) {
    model_leg_length_ = model_sum / static_cast<float>(legs);
    rig_leg_length_ = rig_sum / static_cast<float>(legs);
  }
}

std::vector<std::string> Retargeter::unmapped_joints() const {
  std::vector<std::string> names;
  for (size_t joint = 0; joint < bone_of_joint_.size(); ++joint) {
    if (bone_of_joint_[joint] < 0) names.push_back(model_.name(joint));
  }
  return names;
}

void Retargeter::apply(const std::vector<glm::quat>& model_local, const glm::quat& frame,
                       const glm::vec3& root_position, RigPose& out) const {
  const size_t joints = model_.joint_count();
  if (model_local.size() != joints) {
    throw Error("retarget: " + std::to_string(model_local.size()) + " rotations for " + std::to_string(joints) +
                " model joints");
  }
  out.model_global.resize(joints);
  out.rig_global.resize(rig_.size());
  out.local_rotations.resize(rig_.size());
  out.written = written_;
  for (size_t joint = 0; joint < joints; ++joint) {
    const int parent = model_.parent(joint);
    out.model_global[joint] =
        parent < 0 ? model_local[joint] : out.model_global[static_cast<size_t>(parent)] * model_local[joint];
  }
  for (size_t bone : order_) {
    const RigBone& b = rig_[bone];
    const int joint = joint_of_bone_[bone];
    glm::quat& global = out.rig_global[bone];
    if (joint >= 0) {
      global = frame * out.model_global[static_cast<size_t>(joint)] * alignment_[bone] * rest_global_rotation_[bone];
    } else {
      global = b.parent < 0 ? b.rest_rotation : out.rig_global[static_cast<size_t>(b.parent)] * b.rest_rotation;
    }
    global = glm::normalize(global);
    out.local_rotations[bone] =
        b.parent < 0 ? global : glm::normalize(glm::inverse(out.rig_global[static_cast<size_t>(b.parent)]) * global);
  }
  const RigBone& root = rig_[static_cast<size_t>(root_bone())];
  if (root.parent < 0) {
    out.root_position = root_position;
  } else {
    // Bones above the root keep their rest, so their rest transform places it.
    const size_t parent = static_cast<size_t>(root.parent);
    out.root_position = glm::inverse(rest_global_rotation_[parent]) * (root_position - rest_global_position_[parent]);
  }
}

glm::quat Retargeter::model_global_rotation(size_t bone, const glm::quat& rig_global, const glm::quat& frame) const {
  return glm::normalize(glm::inverse(frame) * rig_global * glm::inverse(alignment_[bone] * rest_global_rotation_[bone]));
}

std::vector<glm::quat> Retargeter::capture(const std::vector<glm::quat>& rig_local, const glm::quat& frame) const {
  if (rig_local.size() != rig_.size()) {
    throw Error("retarget: " + std::to_string(rig_local.size()) + " rotations for " + std::to_string(rig_.size()) +
                " rig bones");
  }
  std::vector<glm::quat> rig_global(rig_.size());
  for (size_t bone : order_) {
    const int parent = rig_[bone].parent;
    rig_global[bone] = parent < 0 ? rig_local[bone] : rig_global[static_cast<size_t>(parent)] * rig_local[bone];
  }
  const size_t joints = model_.joint_count();
  std::vector<glm::quat> model_global(joints), model_local(joints);
  for (size_t joint = 0; joint < joints; ++joint) {
    const int parent = model_.parent(joint);
    const int bone = bone_of_joint_[joint];
    if (bone >= 0) {
      model_global[joint] = model_global_rotation(static_cast<size_t>(bone), rig_global[static_cast<size_t>(bone)], frame);
    } else {
      model_global[joint] = parent < 0 ? glm::quat(1.0f, 0.0f, 0.0f, 0.0f) : model_global[static_cast<size_t>(parent)];
    }
    model_local[joint] = parent < 0 ? model_global[joint]
                                    : glm::normalize(glm::inverse(model_global[static_cast<size_t>(parent)]) * model_global[joint]);
  }
  return model_local;
}

}  // namespace ardy
