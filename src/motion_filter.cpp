#include "motion_filter.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "sampler.hpp"

namespace ardy {

namespace {

// Each joint's 6D rotation in `count` rows replaced by the first two columns
// of a rotation, by Gram-Schmidt from the contract's first column, or from
// the second for the joints `second_first` marks (none: the rotation the
// values stand for). The model's 6D values carry a scale and a skew of
// their own (a first column far from unit length, not orthogonal to the
// second), and Gram-Schmidt leans on the first column: averaging such
// values over neighbouring frames turned a thigh 40 degrees where no frame
// did (the shown knee swung 0.47 m in one frame where the model's moved
// 0.1 m), so the filter averages orthonormal columns instead.
void to_rotation_columns(const FeatureLayout& layout, float* rows, size_t count,
                         const std::vector<bool>* second_first = nullptr) {
  const size_t m = layout.feature_size;
  for (size_t f = 0; f < count; ++f) {
    float* six = rows + f * m + layout.rotation_6d.start;
    for (size_t joint = 0; joint < layout.joint_count; ++joint, six += 6) {
      const bool swap = second_first && (*second_first)[joint];
      const float ordered[6] = {six[swap ? 3 : 0], six[swap ? 4 : 1], six[swap ? 5 : 2],
                                six[swap ? 0 : 3], six[swap ? 1 : 4], six[swap ? 2 : 5]};
      const glm::mat3 rotation = model_rotation_from_6d(ordered);
      for (int axis = 0; axis < 3; ++axis) {
        six[axis] = rotation[swap ? 1 : 0][axis];
        six[3 + axis] = rotation[swap ? 0 : 1][axis];
      }
    }
  }
}

// Per joint, whether the second axis of the rotations in `rows` (orthonormal
// 6D, in time order) turns less from row to row than the first. Where a
// joint twists about one axis from frame to frame (the model's thigh or hips
// turning half a turn about the bone, back and forth), the other two axes
// average to almost nothing, and Gram-Schmidt from either of them would
// turn the bone at random; from the steady one it keeps the bone and leaves
// only the twist to the average.
std::vector<bool> second_axis_steadier(const FeatureLayout& layout, const std::vector<const float*>& rows) {
  std::vector<bool> steadier(layout.joint_count, false);
  for (size_t joint = 0; joint < layout.joint_count; ++joint) {
    double first_turn = 0.0, second_turn = 0.0;
    for (size_t r = 1; r < rows.size(); ++r) {
      const float* now = rows[r] + layout.rotation_6d.start + 6 * joint;
      const float* before = rows[r - 1] + layout.rotation_6d.start + 6 * joint;
      first_turn += 1.0 - (now[0] * before[0] + now[1] * before[1] + now[2] * before[2]);
      second_turn += 1.0 - (now[3] * before[3] + now[4] * before[4] + now[5] * before[5]);
    }
    steadier[joint] = second_turn < first_turn;
  }
  return steadier;
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
  to_rotation_columns(layout, out.data(), count);
  const std::vector<float> source = out;
  frames = source.data();

  std::vector<double> weights(2 * radius + 1);
  for (size_t k = 0; k < weights.size(); ++k) {
    const double d = static_cast<double>(k) - static_cast<double>(radius);
    weights[k] = std::exp(-0.5 * d * d / (sigma_frames * sigma_frames));
  }
  const size_t left = context ? std::min(context_frames, radius) : 0;
  std::vector<float> context_rows;
  if (left) {
    const float* first = context + (context_frames - left) * m;
    context_rows.assign(first, first + left * m);
    to_rotation_columns(layout, context_rows.data(), left);
  }
  const float* first_context = left ? context_rows.data() : nullptr;
  std::vector<const float*> in_time_order;
  for (size_t r = 0; r < left; ++r) in_time_order.push_back(first_context + r * m);
  for (size_t f = 0; f < count; ++f) in_time_order.push_back(frames + f * m);
  const std::vector<bool> second_first = second_axis_steadier(layout, in_time_order);
  const long long lo = -static_cast<long long>(left), last = static_cast<long long>(count) - 1;
  // Row i of [left context frames; new frames]; before them the first one repeats.
  const auto row = [&](long long i) -> const float* {
    i = std::max(i, lo);
    return i < 0 ? first_context + (i + static_cast<long long>(left)) * static_cast<long long>(m)
                 : frames + i * static_cast<long long>(m);
  };
  const FeatureSlice contacts = layout.foot_contacts;
  const auto is_contact = [&](size_t c) { return c >= contacts.start && c < contacts.start + contacts.size; };
  std::vector<double> sum(m);
  for (size_t f = 0; f < count; ++f) {
    std::fill(sum.begin(), sum.end(), 0.0);
    double total = 0.0;
    for (size_t k = 0; k < weights.size(); ++k) {
      const long long i = static_cast<long long>(f + k) - static_cast<long long>(radius);
      if (i <= last) {
        const float* r = row(i);
        for (size_t c = 0; c < m; ++c) sum[c] += weights[k] * r[c];
      } else {
        // Past the last frame the motion goes on as it was going (point reflection
        // through the last frame): a window's end keeps its speed for the next one.
        const float* end = row(last);
        const float* mirror = row(2 * last - i);
        for (size_t c = 0; c < m; ++c) sum[c] += weights[k] * (2.0 * end[c] - mirror[c]);
      }
      total += weights[k];
    }
    float* o = out.data() + f * m;
    for (size_t c = 0; c < m; ++c) {
      if (!is_contact(c)) o[c] = static_cast<float>(sum[c] / total);
    }
  }

  // The join: the frames shown before were filtered with a guess of what
  // follows them (point reflection); where the new frames differ from that
  // guess, the first of them would step. So the first new frame continues
  // the shown ones (linear extrapolation of the last two) and the
  // difference fades out over the next 2 radius frames.
  if (left > 0) {
    const float* last = row(-1);
    const float* before = left > 1 ? row(-2) : last;
    const size_t fade = std::min(2 * radius, count);
    for (size_t c = 0; c < m; ++c) {
      if (is_contact(c)) continue;
      const double gap = 2.0 * last[c] - before[c] - out[c];
      for (size_t f = 0; f < fade; ++f) {
        const double weight = fade > 1 ? 1.0 - static_cast<double>(f) / static_cast<double>(fade - 1) : 1.0;
        out[f * m + c] = static_cast<float>(out[f * m + c] + weight * gap);
      }
    }
  }
  to_rotation_columns(layout, out.data(), count, &second_first);
  for (size_t f = 0; f < count; ++f) {
    float* h = out.data() + f * m + layout.heading.start;
    const float norm = std::hypot(h[0], h[1]);
    if (norm > 1e-6f) {
      h[0] /= norm;
      h[1] /= norm;
    }
  }
  return out;
}

}  // namespace ardy
