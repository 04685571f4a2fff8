#include "motion_filter.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "kinematics.hpp"
#include "sampler.hpp"

namespace ardy {

namespace {

// The filter works on frames with each joint's 6D rotation replaced by its
// unit quaternion: averaging 6D values (or rotation matrices) of a joint that
// turns half a turn between frames (the model's thighs and hips twist about
// the bone and back, its legs sometimes turn over) gives columns near zero,
// and Gram-Schmidt from them turns the bone at random: a knee swung 0.47 m in
// one frame where the model's moved 0.1 m, a toe 23 m/s. Quaternions in one
// hemisphere average to the rotation between (normalized lerp), so a twist
// stays a twist and a turn is spread over the filter's width. Row layout: the
// features without the rotation slice, then 4 values (w, x, y, z) per joint.
struct WorkingRows {
  size_t width = 0;           // values per row
  size_t quaternions = 0;     // where the quaternions start
  std::vector<float> values;  // [rows, width]
  const float* row(size_t r) const { return values.data() + r * width; }
};

WorkingRows to_working(const FeatureLayout& layout, const float* rows, size_t count) {
  const size_t m = layout.feature_size, rotation_start = layout.rotation_6d.start;
  const size_t rotation_end = rotation_start + layout.rotation_6d.size;
  WorkingRows out;
  out.quaternions = m - layout.rotation_6d.size;
  out.width = out.quaternions + 4 * layout.joint_count;
  out.values.resize(count * out.width);
  for (size_t f = 0; f < count; ++f) {
    const float* in = rows + f * m;
    float* o = out.values.data() + f * out.width;
    std::copy(in, in + rotation_start, o);
    std::copy(in + rotation_end, in + m, o + rotation_start);
    for (size_t joint = 0; joint < layout.joint_count; ++joint) {
      const glm::quat q = quat_from_matrix(model_rotation_from_6d(in + rotation_start + 6 * joint));
      float* at = o + out.quaternions + 4 * joint;
      at[0] = q.w;
      at[1] = q.x;
      at[2] = q.y;
      at[3] = q.z;
    }
  }
  return out;
}

// +1 or -1: the sign that puts quaternion q in the hemisphere of `reference`.
float hemisphere_sign(const float* q, const float* reference) {
  return q[0] * reference[0] + q[1] * reference[1] + q[2] * reference[2] + q[3] * reference[3] < 0.0f ? -1.0f
                                                                                                       : 1.0f;
}

// A working row back into a feature row: the quaternions normalized and
// written as the first two columns of their rotation.
void to_features(const FeatureLayout& layout, const WorkingRows& rows, size_t r, float* out) {
  const size_t rotation_start = layout.rotation_6d.start;
  const float* in = rows.row(r);
  std::copy(in, in + rotation_start, out);
  std::copy(in + rotation_start, in + rows.quaternions, out + rotation_start + layout.rotation_6d.size);
  for (size_t joint = 0; joint < layout.joint_count; ++joint) {
    const float* q = in + rows.quaternions + 4 * joint;
    const glm::mat3 rotation = matrix_from_quat(glm::quat(q[0], q[1], q[2], q[3]));
    float* six = out + rotation_start + 6 * joint;
    for (int axis = 0; axis < 3; ++axis) {
      six[axis] = rotation[0][axis];
      six[3 + axis] = rotation[1][axis];
    }
  }
}

}  // namespace

size_t smoothing_radius(double sigma_frames) {
  return sigma_frames > 0.0 ? static_cast<size_t>(std::ceil(3.0 * sigma_frames)) : 0;
}

std::vector<float> smooth_features(const FeatureLayout& layout, const float* context, size_t context_frames,
                                   const float* frames, size_t count, double sigma_frames) {
  const size_t m = layout.feature_size;
  std::vector<float> out(frames, frames + count * m);
  const size_t radius = smoothing_radius(sigma_frames);
  if (radius == 0 || count == 0) return out;

  std::vector<double> weights(2 * radius + 1);
  for (size_t k = 0; k < weights.size(); ++k) {
    const double d = static_cast<double>(k) - static_cast<double>(radius);
    weights[k] = std::exp(-0.5 * d * d / (sigma_frames * sigma_frames));
  }
  const size_t left = context ? std::min(context_frames, radius) : 0;
  const WorkingRows past = to_working(layout, left ? context + (context_frames - left) * m : nullptr, left);
  const WorkingRows now = to_working(layout, frames, count);
  const size_t width = now.width, joints = layout.joint_count, first_quaternion = now.quaternions;
  const long long lo = -static_cast<long long>(left), last = static_cast<long long>(count) - 1;
  // Row i of [left context frames; new frames]; before them the first one repeats.
  const auto row = [&](long long i) -> const float* {
    i = std::max(i, lo);
    return i < 0 ? past.row(static_cast<size_t>(i + static_cast<long long>(left))) : now.row(static_cast<size_t>(i));
  };
  // Foot contacts are flags: never blended (working rows keep them where the features do,
  // the contacts slice lying before or after the rotations).
  const FeatureSlice contacts = layout.foot_contacts;
  const size_t contacts_at =
      contacts.start < layout.rotation_6d.start ? contacts.start : contacts.start - layout.rotation_6d.size;
  const auto is_contact = [&](size_t c) { return c >= contacts_at && c < contacts_at + contacts.size; };
  // a + scale * b, each quaternion of b taken in the hemisphere of a's (the
  // linear steps below, on rotations).
  const auto add = [&](std::vector<double>& sum, const float* reference, const float* values, double scale) {
    for (size_t c = 0; c < first_quaternion; ++c) sum[c] += scale * values[c];
    for (size_t j = 0; j < joints; ++j) {
      const size_t at = first_quaternion + 4 * j;
      const double signed_scale = scale * hemisphere_sign(values + at, reference + at);
      for (size_t k = 0; k < 4; ++k) sum[at + k] += signed_scale * values[at + k];
    }
  };
  // The shown frames' motion continued one frame (linear extrapolation of the
  // last two): where the first new frame has to be so that it does not step.
  std::vector<float> continued;
  if (left > 0) {
    std::vector<double> sum(width, 0.0);
    add(sum, row(-1), row(-1), 2.0);
    add(sum, row(-1), row(left > 1 ? -2 : -1), -1.0);
    continued.assign(sum.begin(), sum.end());
  }

  // Each frame's quaternions are averaged in the hemisphere of its own (a
  // joint the model turns half a turn and back between frames has its
  // quaternion at right angles, then opposite: in one hemisphere from frame to
  // frame they would cancel), and then taken in the hemisphere of the frame
  // before's result, so that the linear join below sees one rotation path.
  WorkingRows filtered = now;
  std::vector<double> sum(width), reflected(width);
  std::vector<float> point(width);  // a reflected row (reused: this runs per window)
  for (size_t f = 0; f < count; ++f) {
    const float* center = now.row(f);
    std::fill(sum.begin(), sum.end(), 0.0);
    double total = 0.0;
    for (size_t k = 0; k < weights.size(); ++k) {
      const long long i = static_cast<long long>(f + k) - static_cast<long long>(radius);
      if (i <= last) {
        add(sum, center, row(i), weights[k]);
      } else {
        // Past the last frame the motion goes on as it was going (point reflection
        // through the last frame): a window's end keeps its speed for the next one.
        const float* end = row(last);
        std::fill(reflected.begin(), reflected.end(), 0.0);
        add(reflected, end, end, 2.0);
        add(reflected, end, row(2 * last - i), -1.0);
        std::copy(reflected.begin(), reflected.end(), point.begin());
        add(sum, center, point.data(), weights[k]);
      }
      total += weights[k];
    }
    float* o = filtered.values.data() + f * width;
    for (size_t c = 0; c < width; ++c) {
      if (!is_contact(c)) o[c] = static_cast<float>(sum[c] / total);
    }
    const float* path = f > 0 ? filtered.row(f - 1) : (left > 0 ? continued.data() : nullptr);
    for (size_t j = 0; path && j < joints; ++j) {
      float* q = o + first_quaternion + 4 * j;
      const float sign = hemisphere_sign(q, path + first_quaternion + 4 * j);
      for (size_t k = 0; k < 4; ++k) q[k] *= sign;
    }
  }

  // The join: the frames shown before were filtered with a guess of what
  // follows them (point reflection); where the new frames differ from that
  // guess, the first of them would step. So the first new frame continues
  // the shown ones and the difference fades out over the next 2 radius frames.
  // A rotation's difference is a rotation: it fades as one (a part of the turn
  // from the first new frame's to the continued one, applied to each frame).
  if (left > 0) {
    const size_t fade = std::min(2 * radius, count);
    const auto weight = [&](size_t f) {
      return fade > 1 ? 1.0 - static_cast<double>(f) / static_cast<double>(fade - 1) : 1.0;
    };
    for (size_t c = 0; c < first_quaternion; ++c) {
      if (is_contact(c)) continue;
      const double gap = double(continued[c]) - filtered.values[c];
      for (size_t f = 0; f < fade; ++f) {
        float& value = filtered.values[f * width + c];
        value = static_cast<float>(value + weight(f) * gap);
      }
    }
    const auto quaternion_at = [](const float* q) { return glm::normalize(glm::quat(q[0], q[1], q[2], q[3])); };
    for (size_t j = 0; j < joints; ++j) {
      const size_t at = first_quaternion + 4 * j;
      const glm::quat gap = quaternion_at(continued.data() + at) * glm::inverse(quaternion_at(filtered.row(0) + at));
      for (size_t f = 0; f < fade; ++f) {
        float* q = filtered.values.data() + f * width + at;
        const glm::quat faded =
            slerp_shortest(glm::quat(1, 0, 0, 0), gap, static_cast<float>(weight(f))) * quaternion_at(q);
        q[0] = faded.w;
        q[1] = faded.x;
        q[2] = faded.y;
        q[3] = faded.z;
      }
    }
  }
  for (size_t f = 0; f < count; ++f) {
    float* o = out.data() + f * m;
    to_features(layout, filtered, f, o);
    float* h = o + layout.heading.start;
    const float norm = std::hypot(h[0], h[1]);
    if (norm > 1e-6f) {
      h[0] /= norm;
      h[1] /= norm;
    }
  }
  return out;
}

}  // namespace ardy
