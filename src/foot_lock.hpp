#pragma once

// Foot locking on the frames the runtime shows (like the output filter,
// never on what the model reads back as history). While the model marks a
// foot as planted (its contact flags) and the ankle is near the ground, the
// ankle stays where it landed, horizontally, by two-bone IK of the leg (hip
// and knee rotations; the foot keeps its world orientation, so the toes
// follow). When the foot lifts off it returns to the model's own path no
// faster than the model's leg moves allows (kFootReturnShare of its step
// plus kFootReturnFloorStep a frame): a foot held while the model's slid
// 0.2 m, lifting slowly, must not jump back (issue 15: a fixed 6-frame
// return moved such legs at up to 2.7x the model's own speed). The
// tokenizer's decoded feet slide (docs/evaluation: foot skate is 2.8x the
// data's); this removes the slide the contact flags see. Constraints win: a
// leg whose joints the window's goals constrain (a keyframe, a foot target)
// is not held on those frames,
// and a held foot starts its return kFootReleaseFrames before them, on the
// model's path by the constrained frame whatever the cap. Elsewhere, whatever
// the IK answers (a hinge knee's side flips where a leg bends sideways), the
// correction it adds to the model's leg changes from one frame to the next
// by no more than keeps the knee and the ankle within a return's bounds: the
// foot lags or slips a little rather than the leg popping. A skeleton without
// two-bone legs above its contact joints has nothing to lock (available() is
// false).

#include <array>
#include <cstddef>
#include <optional>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "features.hpp"
#include "kinematics.hpp"
#include "sampler.hpp"
#include "skeleton.hpp"

namespace ardy {

// Frames before a constrained frame at which a held foot starts its return
// (it is on the model's path at the constrained frame).
constexpr size_t kFootReleaseFrames = 6;
// A returning foot closes its distance to the model's path so that each of
// ankle, knee and toe moves at most 1 + this share times the model's own step
// of that joint plus kFootReturnFloorStep a frame, its motion along the
// shown path included. The model's step is the slower of the shown path's
// and (when the planner passes them) the frames before the output filter,
// there the largest of three frames (patch seams make them uneven): a
// splice's join spreads a jump of the path over several frames, motion of
// the filter that leaves a return less room, not more. The floor lets a foot
// the model keeps still come back too (0.4 m/s at 20 fps: a 0.25 m hold in
// under a second). Near full extension the IK moves the knee many times as
// far as the ankle, so while the knee would outrun its bound, held or
// returning, the foot goes halfway back to moving with the body, up to four
// times (a held foot slips, a return slows). The rate eases in over two
// frames and the last part halves each frame: the return starts and ends
// softly.
constexpr float kFootReturnShare = 0.4f;
constexpr float kFootReturnFloorStep = 0.02f;  // m per model frame
// A foot is planted when its strongest contact flag rises above kFootPlantFlag
// and stays planted until it falls below kFootLiftFlag (no flicker).
constexpr float kFootPlantFlag = 0.6f;
// Frames over which a landing foot eases from the model's path into the hold.
constexpr size_t kFootPlantFrames = 3;
constexpr float kFootLiftFlag = 0.4f;
// Above this ankle height (m) a foot is never held, whatever its flags say.
constexpr float kFootLockHeight = 0.2f;
// A held ankle further than this (m) from the model's own is let go (the
// body has moved on: a root target dragged it, say); once back on the
// model's path it may be held again.
constexpr float kFootLockMaxPull = 0.25f;
// A locked leg's knee stands off the line from hip to ankle by at most the
// model's own change of that plus this a frame (m, 1 m/s): near full
// extension a small change of the leg's stretch moves the knee far (a
// straight leg bending to 0.98 of its length moves a 0.45 m thigh's knee
// 9 cm). Holds in a walk change it by less (0.01 a frame slid them).
constexpr float kFootBendStep = 0.05f;

// What carries over from one shown frame to the next, per leg.
struct FootLockState {
  struct Leg {
    bool planted = false;
    glm::vec2 pin{0.0f};           // where the ankle is held (x, z)
    glm::vec2 shown{0.0f};         // where the ankle was shown (x, z), last frame
    bool returning = false;        // lifted, on its way back to the model's path
    glm::vec2 offset{0.0f};        // shown ankle minus the model's (x, z), last frame
    float return_step = 0.0f;      // how much the offset shrank last frame (m)
    bool has_own = false;          // leg_before is set
    std::array<glm::vec3, 3> leg_before{};    // the model's ankle, knee and toe last frame
    glm::vec3 knee_shown{0.0f};    // the knee as shown last frame
    glm::vec3 ankle_shown{0.0f};   // the ankle as shown last frame
    float bend_shown = 0.0f;       // the knee off the hip-ankle line as shown last frame (m)
    float own_bend_before = 0.0f;  // the model's, last frame
    bool has_model = false;        // model_before is set
    std::array<glm::vec3, 3> model_before{};  // the same before the output filter
    std::array<std::array<float, 3>, 2> model_steps_before{};  // their steps the two frames before
    bool let_go = false;           // pulled too far: not held again until the flags drop or it is back on the path
    size_t held = 0;               // frames held so far (the hold eases in)
    TwoBoneRotations correction;   // the IK's rotations of hip and knee last frame (identity: none)
  };
  std::array<Leg, 2> legs;
};

class FootLocker {
 public:
  // The legs: each contact joint whose parent is not a contact joint is an
  // ankle (its flags: its own and its children's), with its parent (knee)
  // and grandparent (hip) above it.
  FootLocker(const Skeleton& skeleton, const FeatureLayout& layout, const std::vector<std::string>& contact_joints);
  bool available() const { return available_; }

  // Locks the feet in `motion` (all its frames; world rotations, local
  // rotations and positions are updated), reading the contact flags and
  // heading of the same frames' world features [frame_count, M]. `state` is
  // the state after the frame before the first; it becomes the state after
  // the last. `per_frame` (optional) receives the state after each frame.
  // `goal_mask` (optional, [at least frame_count, M], the window's goal mask
  // frame by frame): where the leg's joints are constrained. `model`
  // (optional, the same frames before the output filter): a return is also
  // capped by the leg's step there.
  void apply(const float* features, Motion& motion, FootLockState& state,
             std::vector<FootLockState>* per_frame = nullptr, const float* goal_mask = nullptr,
             const Motion* model = nullptr) const;

 private:
  struct LegJoints {
    size_t hip = 0, knee = 0, ankle = 0;
    std::optional<size_t> toe;     // the ankle's first child, if any
    std::vector<size_t> flags;     // contact flag indices of this foot
    std::vector<size_t> features;  // position and rotation features of the leg's joints (goal mask entries)
  };
  const Skeleton& skeleton_;
  const FeatureLayout& layout_;
  std::vector<LegJoints> legs_;  // at most 2
  bool available_ = false;
};

}  // namespace ardy
