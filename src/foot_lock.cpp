#include "foot_lock.hpp"

#include <algorithm>
#include <optional>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "kinematics.hpp"

namespace ardy {

FootLocker::FootLocker(const Skeleton& skeleton, const FeatureLayout& layout,
                       const std::vector<std::string>& contact_joints)
    : skeleton_(skeleton), layout_(layout) {
  std::vector<std::optional<size_t>> joints;
  for (const std::string& name : contact_joints) joints.push_back(skeleton.find(name));
  const auto is_contact = [&](int joint) {
    return std::any_of(joints.begin(), joints.end(), [&](const auto& j) { return j && int(*j) == joint; });
  };
  for (const auto& joint : joints) {
    if (!joint || is_contact(skeleton.parent(*joint))) continue;
    LegJoints leg;
    leg.ankle = *joint;
    const int knee = skeleton.parent(leg.ankle);
    const int hip = knee > 0 ? skeleton.parent(static_cast<size_t>(knee)) : -1;
    if (hip <= 0) continue;  // no two bones below the root
    leg.knee = static_cast<size_t>(knee);
    leg.hip = static_cast<size_t>(hip);
    for (size_t i = 0; i < joints.size(); ++i) {
      if (joints[i] && (*joints[i] == leg.ankle || skeleton.parent(*joints[i]) == int(leg.ankle))) leg.flags.push_back(i);
    }
    std::vector<size_t> leg_joints{leg.hip, leg.knee, leg.ankle};
    for (size_t child : skeleton.children(leg.ankle)) leg_joints.push_back(child);
    for (size_t j : leg_joints) {
      for (const FeatureSlice& s : {layout.joint_position_of(j), layout.rotation_6d_of(j)}) {
        for (size_t i = s.start; i < s.start + s.size; ++i) leg.features.push_back(i);
      }
    }
    legs_.push_back(leg);
  }
  available_ = !legs_.empty() && legs_.size() <= 2 && contact_joints.size() == layout.contact_count();
}

void FootLocker::apply(const float* features, Motion& motion, FootLockState& state,
                       std::vector<FootLockState>* per_frame, const float* goal_mask) const {
  if (per_frame) per_frame->clear();
  const size_t j = skeleton_.joint_count(), m = layout_.feature_size;
  // Frames from f to the first frame within kFootReleaseFrames on which a
  // goal constrains leg `leg` (none: no goal that soon).
  const auto constrained_in = [&](size_t leg, size_t f) -> std::optional<size_t> {
    if (!goal_mask) return std::nullopt;
    const size_t end = std::min(motion.frame_count, f + kFootReleaseFrames + 1);
    for (size_t g = f; g < end; ++g) {
      for (size_t i : legs_[leg].features) {
        if (goal_mask[g * m + i] > 0.0f) return g - f;
      }
    }
    return std::nullopt;
  };
  for (size_t f = 0; f < motion.frame_count && available_; ++f) {
    const float* row = features + f * m;
    glm::mat3* global = motion.global_rotations.data() + f * j;
    glm::mat3* local = motion.local_rotations.data() + f * j;
    glm::vec3* position = motion.positions.data() + f * j;
    bool moved = false;
    for (size_t leg = 0; leg < legs_.size(); ++leg) {
      const LegJoints& joints = legs_[leg];
      FootLockState::Leg& s = state.legs[leg];
      const glm::vec3 ankle = position[joints.ankle];
      const glm::vec2 own(ankle.x, ankle.z);
      // The model's step of this leg this frame: the slower of ankle and knee
      // (the return moves both; a knee swinging slower than its foot sets it).
      const glm::vec3 knee = position[joints.knee];
      const float knee_step = s.has_own ? glm::length(knee - s.knee_before) : 0.0f;
      const float own_step = s.has_own ? std::min(glm::length(own - s.own_before), knee_step) : 0.0f;
      const glm::vec3 knee_shown_before = s.has_own ? s.knee_shown : knee;
      s.own_before = own;
      s.knee_before = knee;
      s.knee_shown = knee;  // unless the IK below moves it
      s.has_own = true;
      const float psi = heading_angle(row[layout_.heading.start], row[layout_.heading.start + 1]);
      const glm::vec3 bend_axis = heading_rotation(psi) * glm::vec3(1.0f, 0.0f, 0.0f);
      const auto solve = [&](glm::vec2 target) {
        return two_bone_ik(position[joints.hip], knee, ankle, glm::vec3(target.x, ankle.y, target.y), bend_axis);
      };
      const auto knee_after = [&](const TwoBoneRotations& turn) {
        return position[joints.hip] + turn.upper * (knee - position[joints.hip]);
      };
      float flag = 0.0f;
      for (size_t i : joints.flags) flag = std::max(flag, row[layout_.foot_contacts.start + i]);
      const auto smoothstep = [](float a) { return a * a * (3.0f - 2.0f * a); };
      const auto release = [&] {  // from where the foot was last shown
        s.planted = false;
        s.returning = true;
        s.offset = s.shown - own;
        s.return_step = 0.0f;
      };
      const std::optional<size_t> constrained = constrained_in(leg, f);
      const bool down = ankle.y < kFootLockHeight && flag > (s.planted ? kFootLiftFlag : kFootPlantFlag) && !constrained;
      if (!down) s.let_go = false;
      if (down && !s.planted && !s.let_go) {
        // Landing: held where it is shown now. Mid-return it is already off
        // the model's path, at the pin: no easing in.
        const bool returning_now = s.returning;
        s.pin = returning_now ? own + s.offset : own;
        s.planted = true;
        s.returning = false;
        s.held = returning_now ? kFootPlantFrames : 0;
      } else if (!down && s.planted) {
        release();
      }
      if (s.planted && glm::length(s.pin - own) > kFootLockMaxPull) {
        release();  // the body has moved on (a root target dragged it): let the foot follow
        s.let_go = true;
      }
      glm::vec2 target = own;
      if (s.planted) {
        // Eases in: a landing foot still moving comes to rest over a few frames.
        ++s.held;
        const float a = std::min(1.0f, static_cast<float>(s.held) / static_cast<float>(kFootPlantFrames + 1));
        target = own + (s.pin - own) * smoothstep(a);
      } else if (s.returning) {
        // Back toward the model's path no faster than the model's own leg
        // moves allows; a constraint ahead makes it arrive by the constrained frame.
        const float left = glm::length(s.offset);
        const float cap = kFootReturnShare * own_step + kFootReturnFloorStep;
        float step = std::min({cap, s.return_step + 0.5f * cap, std::max(0.5f * left, kFootReturnFloorStep)});
        if (constrained) {
          step = std::max(step, left / static_cast<float>(*constrained + 1));
        } else {
          // Near full extension the IK's knee moves many times as far as the
          // ankle's target: shorten the step while the knee would outrun the
          // model's knee by more than the same share.
          const float knee_cap = (1.0f + kFootReturnShare) * knee_step + kFootReturnFloorStep;
          for (int halvings = 0; halvings < 4 && left > 0.0f && step > 0.25f * kFootReturnFloorStep; ++halvings) {
            const glm::vec2 t = own + s.offset * ((left - std::min(step, left)) / left);
            if (glm::length(knee_after(solve(t)) - knee_shown_before) <= knee_cap) break;
            step *= 0.5f;
          }
        }
        step = std::min(step, left);
        s.return_step = step;
        s.offset = left > 0.0f ? s.offset * ((left - step) / left) : glm::vec2(0.0f);
        if (glm::length(s.offset) < 1e-4f) {
          // Back on the path: a foot let go while still down (a standing
          // model's foot drifting) may be held again, or it would slide on
          // for as long as the flags stay up.
          s.offset = glm::vec2(0.0f);
          s.returning = false;
          s.let_go = false;
        }
        target = own + s.offset;
      }
      s.shown = target;
      if (glm::length(target - own) < 1e-4f) continue;
      const TwoBoneRotations turn = solve(target);
      s.knee_shown = knee_after(turn);
      global[joints.hip] = turn.upper * global[joints.hip];
      global[joints.knee] = turn.lower * global[joints.knee];
      moved = true;  // the foot keeps its world rotation: the toes follow it
    }
    if (moved) {
      for (size_t k = 1; k < j; ++k) {
        const auto parent = static_cast<size_t>(skeleton_.parent(k));
        position[k] = position[parent] + global[parent] * skeleton_.offset(k);
        local[k] = glm::transpose(global[parent]) * global[k];
      }
    }
    if (per_frame) per_frame->push_back(state);
  }
}

}  // namespace ardy
