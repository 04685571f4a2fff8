#include "foot_lock.hpp"

#include <algorithm>
#include <limits>
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
    const std::vector<size_t> below_ankle = skeleton.children(leg.ankle);
    if (!below_ankle.empty()) leg.toe = below_ankle.front();
    std::vector<size_t> leg_joints{leg.hip, leg.knee, leg.ankle};
    leg_joints.insert(leg_joints.end(), below_ankle.begin(), below_ankle.end());
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
                       std::vector<FootLockState>* per_frame, const float* goal_mask, const Motion* model) const {
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
      // The leg's steps this frame (ankle horizontally, knee, toe) on the path
      // shown and in the model's frames before the output filter (`model`,
      // the largest of this frame's and the two before, as patch seams make
      // its steps uneven; without it, the same as shown). A return moves each
      // of them at most (1 + kFootReturnShare) x the slower of the two plus
      // kFootReturnFloorStep, the shown path's own step counted in: a
      // splice's join spreads a jump of the path over several frames, motion
      // of the filter, which leaves the return less room, not more.
      const glm::vec3 knee = position[joints.knee];
      const std::array<glm::vec3, 3> leg_now{ankle, knee, position[joints.toe.value_or(joints.ankle)]};
      const auto steps = [](const std::array<glm::vec3, 3>& now, const std::array<glm::vec3, 3>& before) {
        const glm::vec3 ankle_step = now[0] - before[0];
        return std::array<float, 3>{glm::length(glm::vec2(ankle_step.x, ankle_step.z)),
                                    glm::length(now[1] - before[1]), glm::length(now[2] - before[2])};
      };
      const std::array<float, 3> shown_steps = s.has_own ? steps(leg_now, s.leg_before) : std::array<float, 3>{};
      std::array<float, 3> model_steps = shown_steps;
      if (model) {
        const glm::vec3* unfiltered = model->positions_of(f);
        const std::array<glm::vec3, 3> model_now{unfiltered[joints.ankle], unfiltered[joints.knee],
                                                 unfiltered[joints.toe.value_or(joints.ankle)]};
        if (s.has_model) {
          const std::array<float, 3> now = steps(model_now, s.model_before);
          for (size_t i = 0; i < 3; ++i) {
            model_steps[i] = std::max({now[i], s.model_steps_before[0][i], s.model_steps_before[1][i]});
          }
          s.model_steps_before = {now, s.model_steps_before[0]};
        }
        s.model_before = model_now;
        s.has_model = true;
      }
      std::array<float, 3> bound{};  // how far each may move this frame
      float return_room = std::numeric_limits<float>::max();
      for (size_t i = 0; i < 3; ++i) {
        bound[i] = (1.0f + kFootReturnShare) * std::min(shown_steps[i], model_steps[i]) + kFootReturnFloorStep;
        return_room = std::min(return_room, bound[i] - shown_steps[i]);
      }
      return_room = std::max(0.0f, return_room);
      const glm::vec3 knee_shown_before = s.has_own ? s.knee_shown : knee;
      const glm::vec3 ankle_shown_before = s.has_own ? s.ankle_shown : ankle;
      const float own_ankle_step = s.has_own ? glm::length(ankle - s.leg_before[0]) : 0.0f;
      const bool had_own = s.has_own;
      // Where the foot goes if it keeps last frame's offset from the model's
      // path: the leg moves as the model's does.
      const glm::vec2 with_the_body = s.has_own ? own + s.shown - glm::vec2(s.leg_before[0].x, s.leg_before[0].z) : own;
      s.leg_before = leg_now;
      s.knee_shown = knee;  // unless the IK below moves them
      s.ankle_shown = ankle;
      s.has_own = true;
      const float psi = heading_angle(row[layout_.heading.start], row[layout_.heading.start + 1]);
      const glm::vec3 bend_axis = heading_rotation(psi) * glm::vec3(1.0f, 0.0f, 0.0f);
      const auto solve = [&](glm::vec2 target) {
        return two_bone_ik(position[joints.hip], knee, ankle, glm::vec3(target.x, ankle.y, target.y), bend_axis, true);
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
        const float cap = return_room;
        float step = std::min({cap, s.return_step + 0.5f * cap, std::max(0.5f * left, kFootReturnFloorStep)});
        if (constrained) step = std::max(step, left / static_cast<float>(*constrained + 1));
        step = std::min(step, left);
        target = own + (left > 0.0f ? s.offset * ((left - step) / left) : glm::vec2(0.0f));
      }
      // How far the knee stands off the line from hip to ankle with the ankle
      // at a target (as if the two bones were as long): near full extension
      // it changes fast.
      const glm::vec3 hip = position[joints.hip];
      const float leg_length = glm::length(knee - hip) + glm::length(ankle - knee);
      const auto bend = [&](glm::vec2 at) {
        const float stretch = glm::length(glm::vec3(at.x, ankle.y, at.y) - hip) / leg_length;
        return 0.5f * leg_length * std::sqrt(1.0f - std::min(stretch * stretch, 1.0f));
      };
      const float own_bend = bend(own);
      if ((s.planted || s.returning) && !constrained && had_own) {
        const glm::vec2 wanted = target;
        // Near full extension the IK's knee moves many times as far as the
        // ankle's target: while the knee would outrun the model's knee by more
        // than kFootReturnShare, the foot goes halfway back to moving with the
        // body (a held foot slips a little, a return slows) rather than the
        // knee popping.
        for (int halvings = 0; halvings < 4; ++halvings) {
          if (glm::length(knee_after(solve(target)) - knee_shown_before) <= bound[1]) break;
          target = with_the_body + (target - with_the_body) * 0.5f;
        }
        // A locked leg's bend changes by at most the model's own change plus
        // kFootBendStep a frame; where the target asks more, the foot lands
        // short of it (or past it) on the line from the hip.
        const float allowed = std::abs(own_bend - s.own_bend_before) + kFootBendStep;
        const float wanted_bend = bend(target);
        const float limited = std::clamp(wanted_bend, s.bend_shown - allowed, s.bend_shown + allowed);
        const glm::vec2 above(hip.x, hip.z);
        const glm::vec2 away = target - above;
        if (limited != wanted_bend && glm::length(away) > 1e-4f) {
          // The hip-to-ankle distance of that bend, then the horizontal reach
          // at the ankle's height.
          const float ratio = std::min(1.0f, 2.0f * limited / leg_length);
          const float distance = leg_length * std::sqrt(1.0f - ratio * ratio);
          const float drop = ankle.y - hip.y;
          const float reach = std::sqrt(std::max(0.0f, distance * distance - drop * drop));
          const glm::vec2 before = target;
          target = above + away * (reach / glm::length(away));
          // The slip moves the ankle no faster than its bound (or than the
          // target wanted anyway): the knee gives a little instead.
          const float most = std::max(bound[0], glm::length(before - s.shown));
          const glm::vec2 step = target - s.shown;
          if (glm::length(step) > most) target = s.shown + step * (most / glm::length(step));
        }
        if (s.planted) s.pin += target - wanted;  // held on from where it slipped to
      }
      s.own_bend_before = own_bend;
      if (s.returning) {
        const float left = glm::length(s.offset);
        s.offset = target - own;
        s.return_step = std::max(0.0f, left - glm::length(s.offset));
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
      bool corrected = glm::length(target - own) >= 1e-4f;
      TwoBoneRotations turn = corrected ? solve(target) : TwoBoneRotations{};
      const auto ankle_after = [&](const TwoBoneRotations& rotations) {
        return knee_after(rotations) + rotations.lower * (ankle - knee);
      };
      // The ankle may move (1 + kFootReturnShare) x the model's own 3D step
      // plus the floor, or as far as the IK's full answer moves it anyway.
      const float ankle_bound = std::max((1.0f + kFootReturnShare) * own_ankle_step + kFootReturnFloorStep,
                                         glm::length(ankle_after(turn) - ankle_shown_before));
      const auto within_bounds = [&](const TwoBoneRotations& rotations) {
        return glm::length(knee_after(rotations) - knee_shown_before) <= bound[1] &&
               glm::length(ankle_after(rotations) - ankle_shown_before) <= ankle_bound;
      };
      if (had_own && !constrained && !within_bounds(turn)) {
        // The last guard against a pop: the IK's correction of the model's
        // leg changes from last frame's by no more than keeps the knee and
        // the ankle within their bounds (the largest share of the change
        // that does, by bisection). Where the IK would swing the leg (a far
        // target near full extension, a correction dropped at once) the foot
        // lags its target for a few frames instead.
        const TwoBoneRotations wanted = turn;
        const auto share_of_change = [&](float share) {
          return TwoBoneRotations{slerp_rotation(s.correction.upper, wanted.upper, share),
                                  slerp_rotation(s.correction.lower, wanted.lower, share)};
        };
        float within = 0.0f, beyond = 1.0f;
        for (int i = 0; i < 10; ++i) {
          const float share = 0.5f * (within + beyond);
          (within_bounds(share_of_change(share)) ? within : beyond) = share;
        }
        turn = share_of_change(within);
        corrected = true;
        // Where the ankle is now shown: a hold slips there, a return goes on from there.
        const glm::vec3 ankle_shown = ankle_after(turn);
        target = glm::vec2(ankle_shown.x, ankle_shown.z);
        if (s.planted) {
          s.pin = target;
        } else {
          s.returning = true;
          s.offset = target - own;
        }
      }
      s.correction = turn;  // identity where nothing was corrected
      s.shown = target;
      s.bend_shown = bend(target);
      if (!corrected) continue;
      s.knee_shown = knee_after(turn);
      s.ankle_shown = ankle_after(turn);
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
