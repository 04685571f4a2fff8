#pragma once

// The output filter: a Gaussian over time on decoded world features, applied
// to the frames the runtime shows (never to what the model reads back as
// history). The tokenizer decodes 4-frame patches whose seams make the raw
// motion jerky (on the default model, jerk across a patch seam is 3.3x that
// inside a patch, and 2.4x the dataset's overall); the shipped sigma, 1 frame,
// brings the jerk under the dataset's (numbers in docs/evaluation).

#include <cstddef>
#include <vector>

#include "features.hpp"

namespace ardy {

// Smoothed copy of `count` new frames of world features [count, M]. Up to
// 3 sigma frames of `context` (the frames shown just before them,
// [context_frames, M], left as they are) are read on the left; past the last
// new frame the motion is continued by point reflection through it (so a
// straight line stays straight up to the window's end). With context, the
// first new frame continues the last two context frames (linear
// extrapolation) and the difference to the filtered frames fades out over
// 2 * radius frames, so a window joins the frames shown before it without a
// step. Every feature but the foot contacts is filtered; the heading's
// (cos, sin) is renormalized, and the 6D rotations are smoothed as unit
// quaternions kept in one hemisphere from frame to frame (written back as
// the columns of their rotations). sigma_frames <= 0 copies.
std::vector<float> smooth_features(const FeatureLayout& layout, const float* context, size_t context_frames,
                                   const float* frames, size_t count, double sigma_frames);

// The largest sigma accepted where a sigma enters (model.json, planner, CLI).
constexpr double kMaxSmoothingFrames = 10.0;

// Frames of context smooth_features reads for this sigma (0 when off).
size_t smoothing_radius(double sigma_frames);

}  // namespace ardy
