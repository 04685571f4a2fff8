#include "motion_filter.hpp"

#include <algorithm>
#include <cmath>

namespace ardy {

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
  const float* first_context = left ? context + (context_frames - left) * m : nullptr;
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
