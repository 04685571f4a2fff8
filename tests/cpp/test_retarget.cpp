// retarget: bone name matching, and the transfer of a pose onto rigs whose
// rest poses and proportions differ from the model's.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "kinematics.hpp"
#include "retarget.hpp"
#include "support/error_message.hpp"
#include "support/skeletons.hpp"

using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;

namespace {

glm::quat random_rotation(std::mt19937& rng, float max_angle) {
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::uniform_real_distribution<float> angle(-max_angle, max_angle);
  glm::vec3 axis(normal(rng), normal(rng), normal(rng));
  return glm::angleAxis(angle(rng), glm::normalize(axis));
}

// A rig shaped like the model skeleton (same hierarchy), with its bones
// renamed, scaled by `scale` and given arbitrary rest rotations: each
// bone's rest rotation is random, and its children's rest offsets are
// expressed in that rotated frame, so the rest pose in space stays the
// model's T-pose (scaled), or an A-pose when `arms_down` rotates the upper
// arms' rest 40 degrees down.
std::vector<ardy::RigBone> rig_from_model(const ardy::Skeleton& model, const std::vector<std::string>& names,
                                          float scale, bool arms_down, std::mt19937& rng) {
  const size_t joints = model.joint_count();
  std::vector<glm::quat> global(joints);
  std::vector<glm::vec3> position(joints);
  for (size_t joint = 0; joint < joints; ++joint) {
    glm::quat pose_rotation(1.0f, 0.0f, 0.0f, 0.0f);
    const std::string& name = model.name(joint);
    if (arms_down && name == "UpperArm_L") pose_rotation = glm::angleAxis(-0.7f, glm::vec3(0, 0, 1));
    if (arms_down && name == "UpperArm_R") pose_rotation = glm::angleAxis(0.7f, glm::vec3(0, 0, 1));
    const int parent = model.parent(joint);
    const glm::quat parent_shape = parent < 0 ? glm::quat(1, 0, 0, 0) : global[static_cast<size_t>(parent)];
    global[joint] = parent_shape * pose_rotation;  // rest "shape" rotation (A-pose arms)
    position[joint] = parent < 0 ? glm::vec3(0, 0.9f * scale, 0)
                                 : position[static_cast<size_t>(parent)] + parent_shape * (scale * model.offset(joint));
  }
  // Arbitrary rest rotations on top of the shape: a bone's frame is its
  // shape rotation times a random twist; positions stay where they are.
  std::vector<glm::quat> frame(joints);
  for (size_t joint = 0; joint < joints; ++joint) frame[joint] = global[joint] * random_rotation(rng, 3.0f);
  std::vector<ardy::RigBone> rig(joints);
  for (size_t joint = 0; joint < joints; ++joint) {
    const int parent = model.parent(joint);
    rig[joint].name = names[joint];
    rig[joint].parent = parent;
    if (parent < 0) {
      rig[joint].rest_rotation = frame[joint];
      rig[joint].rest_position = position[joint];
    } else {
      const glm::quat parent_frame = frame[static_cast<size_t>(parent)];
      rig[joint].rest_rotation = glm::inverse(parent_frame) * frame[joint];
      rig[joint].rest_position = glm::inverse(parent_frame) * (position[joint] - position[static_cast<size_t>(parent)]);
    }
  }
  return rig;
}

struct RigGlobals {
  std::vector<glm::quat> rotations;
  std::vector<glm::vec3> positions;
};

RigGlobals rig_fk(const std::vector<ardy::RigBone>& rig, const ardy::RigPose& pose, int root_bone) {
  RigGlobals out{std::vector<glm::quat>(rig.size()), std::vector<glm::vec3>(rig.size())};
  for (size_t bone = 0; bone < rig.size(); ++bone) {  // parents come first in these rigs
    const glm::quat local = pose.written[bone] ? pose.local_rotations[bone] : rig[bone].rest_rotation;
    const glm::vec3 offset = static_cast<int>(bone) == root_bone ? pose.root_position : rig[bone].rest_position;
    const int parent = rig[bone].parent;
    if (parent < 0) {
      out.rotations[bone] = local;
      out.positions[bone] = offset;
    } else {
      out.rotations[bone] = out.rotations[static_cast<size_t>(parent)] * local;
      out.positions[bone] = out.positions[static_cast<size_t>(parent)] + out.rotations[static_cast<size_t>(parent)] * offset;
    }
  }
  return out;
}

std::vector<glm::quat> random_model_pose(const ardy::Skeleton& model, std::mt19937& rng) {
  std::vector<glm::quat> local(model.joint_count());
  for (auto& rotation : local) rotation = random_rotation(rng, 1.2f);
  return local;
}

float degrees_between(const glm::vec3& a, const glm::vec3& b) {
  const float cosine = glm::dot(glm::normalize(a), glm::normalize(b));
  return std::acos(std::clamp(cosine, -1.0f, 1.0f)) * 57.2957795f;
}

const std::vector<std::string> kHumanoidNames{
    "Hips",          "Spine",        "Chest",        "Neck",          "Head",         "LeftShoulder", "LeftUpperArm",
    "LeftLowerArm",  "LeftHand",     "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand",   "LeftUpperLeg",
    "LeftLowerLeg",  "LeftFoot",     "LeftToes",     "RightUpperLeg", "RightLowerLeg", "RightFoot",   "RightToes"};

}  // namespace

TEST_CASE("humanoid profile names of the model's joints") {
  CHECK(ardy::humanoid_profile_name("Hand_L") == "LeftHand");
  CHECK(ardy::humanoid_profile_name("UpperLeg_R") == "RightUpperLeg");
  CHECK(ardy::humanoid_profile_name("Chest") == "Chest");
  CHECK(ardy::humanoid_profile_name("Tail").empty());
}

TEST_CASE("bones match by model name, humanoid profile name, Mixamo name and explicit map") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  const auto rig_of = [](const std::vector<std::string>& names) {
    std::vector<ardy::RigBone> rig;
    for (const std::string& name : names) rig.push_back({name, -1, {}, {}});
    return rig;
  };

  SECTION("the model's own names, in another order and case") {
    std::vector<std::string> names = model.names();
    std::reverse(names.begin(), names.end());
    names[0] = "TOES_R";
    const auto map = ardy::match_bones(model, rig_of(names));
    for (size_t joint = 0; joint < model.joint_count(); ++joint) {
      CHECK(map[joint] == static_cast<int>(model.joint_count() - 1 - joint));
    }
  }
  SECTION("SkeletonProfileHumanoid names, with UpperChest and fingers left over") {
    std::vector<std::string> names = kHumanoidNames;
    names.insert(names.begin() + 3, "UpperChest");
    names.push_back("LeftIndexProximal");
    const auto map = ardy::match_bones(model, rig_of(names));
    CHECK(map[*model.find("Chest")] == 2);
    CHECK(map[*model.find("Neck")] == 4);
    CHECK(map[*model.find("Hand_L")] == 9);
    CHECK(std::count(map.begin(), map.end(), -1) == 0);
  }
  SECTION("Mixamo names with the mixamorig: prefix") {
    const std::vector<std::string> names{
        "mixamorig:Hips",         "mixamorig:Spine",       "mixamorig:Spine1",      "mixamorig:Spine2",
        "mixamorig:Neck",         "mixamorig:Head",        "mixamorig:LeftShoulder", "mixamorig:LeftArm",
        "mixamorig:LeftForeArm",  "mixamorig:LeftHand",    "mixamorig:RightShoulder", "mixamorig:RightArm",
        "mixamorig:RightForeArm", "mixamorig:RightHand",   "mixamorig:LeftUpLeg",   "mixamorig:LeftLeg",
        "mixamorig:LeftFoot",     "mixamorig:LeftToeBase", "mixamorig:RightUpLeg",  "mixamorig:RightLeg",
        "mixamorig:RightFoot",    "mixamorig:RightToeBase"};
    const auto map = ardy::match_bones(model, rig_of(names));
    CHECK(map[*model.find("Chest")] == 3);
    CHECK(map[*model.find("UpperArm_L")] == 7);
    CHECK(map[*model.find("LowerLeg_R")] == 19);
    CHECK(std::count(map.begin(), map.end(), -1) == 0);
  }
  SECTION("an explicit map wins, and an explicit name the rig lacks stays unmapped") {
    const auto map = ardy::match_bones(model, rig_of({"Hips", "Spine", "Torso", "Chest"}),
                                       {{"Chest", "Torso"}, {"Spine", "NoSuchBone"}});
    CHECK(map[*model.find("Chest")] == 2);
    CHECK(map[*model.find("Spine")] == -1);
    CHECK(map[*model.find("Hips")] == 0);
  }
}

TEST_CASE("a rig identical to the model gets the model's local rotations") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  std::vector<ardy::RigBone> rig;
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    rig.push_back({model.name(joint), model.parent(joint), model.offset(joint), glm::quat(1, 0, 0, 0)});
  }
  const ardy::Retargeter retargeter(model, rig, ardy::match_bones(model, rig));
  CHECK(retargeter.unmapped_joints().empty());
  CHECK(retargeter.rig_leg_length() == Catch::Approx(retargeter.model_leg_length()));
  std::mt19937 rng(7);
  const auto local = random_model_pose(model, rng);
  ardy::RigPose pose;
  retargeter.apply(local, glm::quat(1, 0, 0, 0), glm::vec3(1, 2, 3), pose);
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    CHECK(std::abs(glm::dot(pose.local_rotations[joint], local[joint])) == Catch::Approx(1.0f).margin(1e-5));
  }
  CHECK(glm::length(pose.root_position - glm::vec3(1, 2, 3)) < 1e-6f);
}

TEST_CASE("rigs with other proportions, rest rotations and an A-pose get the model's bone directions") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  std::mt19937 rng(11);
  for (bool arms_down : {false, true}) {
    const std::vector<ardy::RigBone> rig = rig_from_model(model, kHumanoidNames, 1.3f, arms_down, rng);
    const ardy::Retargeter retargeter(model, rig, ardy::match_bones(model, rig));
    CHECK(retargeter.rig_leg_length() / retargeter.model_leg_length() == Catch::Approx(1.3f).epsilon(1e-4));
    // The rig's rest pose shows the model's rest pose.
    {
      ardy::RigPose rest;
      retargeter.apply(std::vector<glm::quat>(model.joint_count(), glm::quat(1, 0, 0, 0)), glm::quat(1, 0, 0, 0),
                       rig[0].rest_position, rest);
      const RigGlobals globals = rig_fk(rig, rest, retargeter.root_bone());
      for (size_t joint = 1; joint < model.joint_count(); ++joint) {
        const size_t parent = static_cast<size_t>(model.parent(joint));
        const glm::vec3 rig_direction = globals.positions[joint] - globals.positions[parent];
        INFO("arms_down " << arms_down << ", bone " << model.name(parent) << " -> " << model.name(joint));
        CHECK(degrees_between(rig_direction, model.offset(joint)) < 0.05f);
      }
    }
    // Random poses under a turned frame: directions agree with the model's FK.
    const glm::quat frame = glm::angleAxis(0.8f, glm::vec3(0, 1, 0));
    for (int trial = 0; trial < 20; ++trial) {
      const auto local = random_model_pose(model, rng);
      std::vector<glm::mat3> local_matrices;
      for (const auto& q : local) local_matrices.push_back(ardy::matrix_from_quat(q));
      const ardy::GlobalPose model_pose = ardy::forward_kinematics(model, glm::vec3(0), local_matrices);
      ardy::RigPose pose;
      retargeter.apply(local, frame, glm::vec3(0.5f, 1.0f, -2.0f), pose);
      const RigGlobals globals = rig_fk(rig, pose, retargeter.root_bone());
      CHECK(glm::length(globals.positions[0] - glm::vec3(0.5f, 1.0f, -2.0f)) < 1e-5f);
      for (size_t joint = 1; joint < model.joint_count(); ++joint) {
        const size_t parent = static_cast<size_t>(model.parent(joint));
        const glm::vec3 rig_direction = globals.positions[joint] - globals.positions[parent];
        const glm::vec3 model_direction = frame * (model_pose.positions[joint] - model_pose.positions[parent]);
        INFO("trial " << trial << ", bone " << model.name(parent) << " -> " << model.name(joint));
        CHECK(degrees_between(rig_direction, model_direction) < 0.05f);
      }
    }
  }
}

TEST_CASE("unmapped bones between mapped ones keep their rest; bones below the leaves are not written") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  std::vector<ardy::RigBone> rig;
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    rig.push_back({model.name(joint), model.parent(joint), model.offset(joint), glm::quat(1, 0, 0, 0)});
  }
  // A root bone above the hips, a twist bone inside the spine, a finger.
  const glm::quat root_rest = glm::angleAxis(0.3f, glm::vec3(0, 1, 0));
  rig.push_back({"Root", -1, glm::vec3(0, 0, 0), root_rest});
  rig[0].parent = 21;
  rig.push_back({"SpineTwist", 1, glm::vec3(0, 0.05f, 0), glm::angleAxis(0.2f, glm::vec3(0, 1, 0))});
  rig[2].parent = 22;
  rig.push_back({"Finger", 8, glm::vec3(0.05f, 0, 0), glm::quat(1, 0, 0, 0)});
  const ardy::Retargeter retargeter(model, rig, ardy::match_bones(model, rig));
  std::mt19937 rng(3);
  ardy::RigPose pose;
  retargeter.apply(random_model_pose(model, rng), glm::quat(1, 0, 0, 0), glm::vec3(0, 1, 0), pose);
  CHECK(pose.written[21]);
  CHECK(pose.written[22]);
  CHECK_FALSE(pose.written[23]);
  CHECK(std::abs(glm::dot(pose.local_rotations[21], root_rest)) == Catch::Approx(1.0f).margin(1e-6));
  CHECK(std::abs(glm::dot(pose.local_rotations[22], rig[22].rest_rotation)) == Catch::Approx(1.0f).margin(1e-6));
  // The hips land at (0, 1, 0) in skeleton space through the turned root bone.
  CHECK(glm::length(root_rest * pose.root_position - glm::vec3(0, 1, 0)) < 1e-6f);
}

TEST_CASE("a rig without the model's root joint is refused by name") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  const std::vector<ardy::RigBone> rig{{"Spine", -1, {}, {}}};
  CHECK_THAT(error_message([&] { ardy::Retargeter(model, rig, ardy::match_bones(model, rig)); }),
             ContainsSubstring("root joint 'Hips'"));
}

TEST_CASE("capturing a retargeted rig pose gives the model pose back") {
  const ardy::Skeleton model = ardy_test::ardy_test_skeleton();
  std::mt19937 rng(5);
  const std::vector<ardy::RigBone> rig = rig_from_model(model, kHumanoidNames, 0.8f, true, rng);
  const ardy::Retargeter retargeter(model, rig, ardy::match_bones(model, rig));
  const glm::quat frame = glm::angleAxis(-1.1f, glm::vec3(0, 1, 0));
  const auto local = random_model_pose(model, rng);
  ardy::RigPose pose;
  retargeter.apply(local, frame, glm::vec3(0, 1, 0), pose);
  const std::vector<glm::quat> captured = retargeter.capture(pose.local_rotations, frame);
  for (size_t joint = 0; joint < model.joint_count(); ++joint) {
    INFO(model.name(joint));
    CHECK(std::abs(glm::dot(captured[joint], local[joint])) == Catch::Approx(1.0f).margin(1e-4));
  }
}
