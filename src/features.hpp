#pragma once

// The per-frame feature vector (design.md section 4) and the operations on
// it: layout (read from the model package), packing and unpacking of one
// frame, normalization, patching frames into tokens, and translation-only
// re-centering.
//
// Default layout for j joints (j = 21 gives M = 258):
//
//   root_position      3        p: root (Hips) world position x, y, z
//   heading            2        cos psi, sin psi
//   rotation_6d        6 j      world rotation of every joint, 6D, joint-major
//   joint_positions    3 (j-1)  world positions of joints 1.. minus (p.x, 0, p.z)
//   joint_velocities   3 j      world velocities of every joint (m/s)
//   foot_contacts      c        contact flags (0 or 1)
//
// The root part of a frame is root_position followed by heading (5 values);
// the body is everything else, and is contiguous. A hybrid token holds the
// root of its P frames, frame-major (5 P values), then its latent body.

#include <cstddef>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json_fwd.hpp>

#include "error.hpp"

namespace ardy {

// Features [start, start + size) of a frame.
struct FeatureSlice {
  size_t start = 0;
  size_t size = 0;
  size_t stop() const { return start + size; }
  bool operator==(const FeatureSlice& other) const { return start == other.start && size == other.size; }
  bool operator!=(const FeatureSlice& other) const { return !(*this == other); }
};

struct FeatureLayout {
  size_t joint_count = 0;
  size_t feature_size = 0;  // M
  FeatureSlice root_position;
  FeatureSlice heading;
  FeatureSlice rotation_6d;
  FeatureSlice joint_positions;
  FeatureSlice joint_velocities;
  FeatureSlice foot_contacts;

  // The design's order and sizes for `joint_count` joints and
  // `contact_count` contact flags.
  static FeatureLayout ardy_default(size_t joint_count, size_t contact_count = 4);

  // From the model package's layout object: every slice by name as
  // [start, stop] (Python slice bounds), e.g. {"root_position": [0, 3],
  // "heading": [3, 5], "rotation_6d": [5, 131], "joint_positions": [131, 191],
  // "joint_velocities": [191, 254], "foot_contacts": [254, 258]}. An optional
  // "feature_size" must equal the total. Unknown or missing names, slices of
  // the wrong size for `joint_count`, overlaps and gaps throw Error naming
  // the slice.
  static FeatureLayout from_json(const nlohmann::json& layout, size_t joint_count);
  nlohmann::json to_json() const;

  // Throws Error unless the slices tile [0, feature_size) with the sizes
  // above, and root_position is directly followed by heading, at the start
  // or at the end of the frame.
  void validate() const;

  FeatureSlice root() const { return {root_position.start, root_position.size + heading.size}; }
  FeatureSlice body() const;
  size_t root_size() const { return root_position.size + heading.size; }  // 5
  size_t body_size() const { return feature_size - root_size(); }
  size_t contact_count() const { return foot_contacts.size; }
  FeatureSlice rotation_6d_of(size_t joint) const;        // 6 values
  FeatureSlice joint_position_of(size_t joint) const;     // 3 values; joint >= 1 (the root uses root_position)
  FeatureSlice joint_velocity_of(size_t joint) const;     // 3 values

  bool operator==(const FeatureLayout& other) const;
  bool operator!=(const FeatureLayout& other) const { return !(*this == other); }
};

// One frame in explicit form: world space, metres, the skeleton's joint order.
struct MotionFrame {
  glm::vec3 root_position{0.0f};
  float heading_cos = 1.0f;  // cos psi, sin psi as stored (unpacked values are not re-normalized)
  float heading_sin = 0.0f;
  std::vector<glm::mat3> rotations;   // world rotation per joint
  std::vector<glm::vec3> positions;   // world position per joint (positions[0] is the root)
  std::vector<glm::vec3> velocities;  // world velocity per joint
  std::vector<float> contacts;        // contact_count() flags

  float heading() const;  // psi = atan2(sin, cos)
};

// Writes one frame's features (layout.feature_size floats). positions[0] is
// not stored (the root is root_position); joint positions are stored minus
// (p.x, 0, p.z). Throws Error when a vector's size does not match the layout.
void pack_frame(const FeatureLayout& layout, const MotionFrame& frame, float* features);

// Reads one frame: rotations by Gram-Schmidt from 6D, positions[0] =
// root_position and positions[j] = stored + (p.x, 0, p.z).
void unpack_frame(const FeatureLayout& layout, const float* features, MotionFrame& frame);
MotionFrame unpack_frame(const FeatureLayout& layout, const float* features);

// Per-feature mean and standard deviation (the package's statistics).
class Normalization {
 public:
  // Same sizes, finite values, std > 0; `what` names the statistics in errors.
  Normalization(std::vector<float> mean, std::vector<float> stddev, const std::string& what = "normalization");

  size_t size() const { return mean_.size(); }
  const std::vector<float>& mean() const { return mean_; }
  const std::vector<float>& stddev() const { return stddev_; }

  // In place over `rows` consecutive rows of size() values: x -> (x - mean) / std.
  void normalize(float* data, size_t rows) const;
  void denormalize(float* data, size_t rows) const;
  // In place over `groups` consecutive groups of `features.size` values that
  // hold features [features.start, features.stop) (e.g. the 5 root values of
  // each of a token's P frames).
  void normalize(float* data, size_t groups, FeatureSlice features) const;
  void denormalize(float* data, size_t groups, FeatureSlice features) const;

 private:
  void check_slice(FeatureSlice features) const;
  std::vector<float> mean_;
  std::vector<float> stddev_;
};

// --- patching ----------------------------------------------------------------
// Frames are row-major [frame_count, M]. Tokens of explicit features are the
// same memory viewed as [frame_count / P, P * M] (frame-major), so only the
// root needs gathering.

// Roots of frame_count frames -> [frame_count / P, 5 P]. frame_count must be
// a multiple of patch (Error otherwise).
std::vector<float> gather_root_tokens(const FeatureLayout& layout, const float* frames, size_t frame_count,
                                      size_t patch);
// The inverse: writes the roots of [token_count, 5 P] into token_count * P frames.
void scatter_root_tokens(const FeatureLayout& layout, const float* root_tokens, size_t token_count, size_t patch,
                         float* frames);

// Hybrid tokens [count, 5 P + L] from roots [count, 5 P] and latents [count, L].
std::vector<float> make_hybrid_tokens(const FeatureLayout& layout, const float* root_tokens, const float* latents,
                                      size_t count, size_t patch, size_t latent_size);
// Splits hybrid tokens [count, 5 P + L] into roots [count, 5 P] and latents [count, L].
void split_hybrid_tokens(const FeatureLayout& layout, const float* tokens, size_t count, size_t patch,
                         size_t latent_size, std::vector<float>& root_tokens, std::vector<float>& latents);

// --- re-centering (translation only) -------------------------------------------
// Unnormalized world-space values. The offset is (x, 0, z) of a root
// position; heights, heading, rotations, joint positions (already relative
// to the planar root), velocities and contacts are untouched.

// (x, 0, z) of frame `anchor_frame`'s root position.
glm::vec3 planar_root_offset(const FeatureLayout& layout, const float* frames, size_t frame_count,
                             size_t anchor_frame);
// Subtracts / adds the offset's x and z to the root position of every frame.
void recenter_frames(const FeatureLayout& layout, float* frames, size_t frame_count, const glm::vec3& offset);
void uncenter_frames(const FeatureLayout& layout, float* frames, size_t frame_count, const glm::vec3& offset);
// The same on tokens [token_count, token_size] that start with the roots of
// their P frames (hybrid tokens, or root tokens with token_size = 5 P).
void recenter_token_roots(const FeatureLayout& layout, float* tokens, size_t token_count, size_t token_size,
                          size_t patch, const glm::vec3& offset);
void uncenter_token_roots(const FeatureLayout& layout, float* tokens, size_t token_count, size_t token_size,
                          size_t patch, const glm::vec3& offset);

}  // namespace ardy
