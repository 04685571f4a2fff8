#include "features.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <nlohmann/json.hpp>

#include "kinematics.hpp"

namespace ardy {
namespace {

struct NamedSlice {
  const char* name;
  FeatureSlice FeatureLayout::*member;
};

// JSON names, in the default order.
constexpr NamedSlice kSlices[] = {
    {"root_position", &FeatureLayout::root_position},     {"heading", &FeatureLayout::heading},
    {"rotation_6d", &FeatureLayout::rotation_6d},         {"joint_positions", &FeatureLayout::joint_positions},
    {"joint_velocities", &FeatureLayout::joint_velocities}, {"foot_contacts", &FeatureLayout::foot_contacts},
};

std::string bounds(FeatureSlice s) { return "[" + std::to_string(s.start) + ", " + std::to_string(s.stop()) + ")"; }

std::string count_mismatch(const char* what, size_t found, size_t expected) {
  return std::string(what) + ": " + std::to_string(found) + " entries, the layout needs " + std::to_string(expected);
}

void check_patch(const char* what, size_t patch) {
  if (patch == 0) throw Error(std::string(what) + ": the patch size must be positive");
}

void shift_token_roots(const FeatureLayout& layout, float* tokens, size_t token_count, size_t token_size,
                       size_t patch, float dx, float dz, const char* what) {
  check_patch(what, patch);
  const size_t root = layout.root_size();
  if (token_size < patch * root) {
    throw Error(std::string(what) + ": tokens of " + std::to_string(token_size) + " values cannot hold the roots of " +
                std::to_string(patch) + " frames (" + std::to_string(patch * root) + " values)");
  }
  for (size_t t = 0; t < token_count; ++t) {
    float* token = tokens + t * token_size;
    for (size_t p = 0; p < patch; ++p) {
      token[p * root + 0] += dx;  // the root block starts with the root position (validate())
      token[p * root + 2] += dz;
    }
  }
}

void shift_frames(const FeatureLayout& layout, float* frames, size_t frame_count, float dx, float dz) {
  for (size_t f = 0; f < frame_count; ++f) {
    float* p = frames + f * layout.feature_size + layout.root_position.start;
    p[0] += dx;
    p[2] += dz;
  }
}

}  // namespace

// --- FeatureLayout --------------------------------------------------------------

FeatureLayout FeatureLayout::ardy_default(size_t joint_count, size_t contact_count) {
  if (joint_count == 0) throw Error("feature layout: the skeleton has no joints");
  FeatureLayout layout;
  layout.joint_count = joint_count;
  size_t at = 0;
  const auto next = [&](size_t size) {
    const FeatureSlice slice{at, size};
    at += size;
    return slice;
  };
  layout.root_position = next(3);
  layout.heading = next(2);
  layout.rotation_6d = next(6 * joint_count);
  layout.joint_positions = next(3 * (joint_count - 1));
  layout.joint_velocities = next(3 * joint_count);
  layout.foot_contacts = next(contact_count);
  layout.feature_size = at;
  return layout;
}

FeatureLayout FeatureLayout::from_json(const nlohmann::json& json, size_t joint_count) {
  if (!json.is_object()) throw Error("feature layout: expected an object of named slices, got " + json.dump());
  FeatureLayout layout;
  layout.joint_count = joint_count;
  for (auto it = json.begin(); it != json.end(); ++it) {
    if (it.key() == "feature_size") continue;
    const bool known = std::any_of(std::begin(kSlices), std::end(kSlices),
                                   [&](const NamedSlice& s) { return it.key() == s.name; });
    if (!known) {
      std::string names;
      for (const NamedSlice& s : kSlices) names += std::string(names.empty() ? "" : ", ") + s.name;
      throw Error("feature layout: unknown slice '" + it.key() + "' (expected " + names + ")");
    }
  }
  size_t total = 0;
  for (const NamedSlice& s : kSlices) {
    const auto found = json.find(s.name);
    if (found == json.end()) throw Error(std::string("feature layout: missing slice '") + s.name + "'");
    const nlohmann::json& value = *found;
    const auto bound = [](const nlohmann::json& v) {
      return v.is_number_integer() && v.get<int64_t>() >= 0 && v.get<int64_t>() <= (int64_t{1} << 20);
    };
    const bool pair = value.is_array() && value.size() == 2 && bound(value[0]) && bound(value[1]) &&
                      value[0].get<int64_t>() <= value[1].get<int64_t>();
    if (!pair) {
      throw Error(std::string("feature layout: slice '") + s.name +
                  "' must be [start, stop] with 0 <= start <= stop, got " + value.dump());
    }
    const auto start = static_cast<size_t>(value[0].get<int64_t>());
    const auto stop = static_cast<size_t>(value[1].get<int64_t>());
    layout.*(s.member) = FeatureSlice{start, stop - start};
    total = std::max(total, stop);
  }
  layout.feature_size = total;
  if (const auto size = json.find("feature_size"); size != json.end()) {
    if (!size->is_number_integer() || size->get<int64_t>() != static_cast<int64_t>(total)) {
      throw Error("feature layout: feature_size is " + size->dump() + " but the slices end at " +
                  std::to_string(total));
    }
  }
  layout.validate();
  return layout;
}

nlohmann::json FeatureLayout::to_json() const {
  nlohmann::json out = nlohmann::json::object();
  for (const NamedSlice& s : kSlices) {
    const FeatureSlice slice = this->*(s.member);
    out[s.name] = {slice.start, slice.stop()};
  }
  out["feature_size"] = feature_size;
  return out;
}

void FeatureLayout::validate() const {
  if (joint_count == 0) throw Error("feature layout: the skeleton has no joints");
  const std::string joints = std::to_string(joint_count) + " joints";
  const auto expect = [&](const char* name, FeatureSlice slice, size_t expected, const std::string& why) {
    if (slice.size != expected) {
      throw Error(std::string("feature layout: '") + name + "' " + bounds(slice) + " has " +
                  std::to_string(slice.size) + " values, expected " + std::to_string(expected) + " (" + why + ")");
    }
  };
  expect("root_position", root_position, 3, "x, y, z");
  expect("heading", heading, 2, "cos, sin");
  expect("rotation_6d", rotation_6d, 6 * joint_count, "6 per joint, " + joints);
  expect("joint_positions", joint_positions, 3 * (joint_count - 1), "3 per non-root joint, " + joints);
  expect("joint_velocities", joint_velocities, 3 * joint_count, "3 per joint, " + joints);

  // The slices tile [0, feature_size) without gaps or overlaps.
  std::vector<std::pair<FeatureSlice, const char*>> sorted;
  for (const NamedSlice& s : kSlices) {
    if ((this->*(s.member)).size > 0) sorted.emplace_back(this->*(s.member), s.name);
  }
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.first.start < b.first.start; });
  size_t at = 0;
  for (const auto& [slice, name] : sorted) {
    if (slice.start < at) {
      throw Error(std::string("feature layout: '") + name + "' " + bounds(slice) +
                  " overlaps the slice before it (which ends at " + std::to_string(at) + ")");
    }
    if (slice.start > at) {
      throw Error("feature layout: features [" + std::to_string(at) + ", " + std::to_string(slice.start) +
                  ") belong to no slice");
    }
    at = slice.stop();
  }
  if (at != feature_size) {
    throw Error("feature layout: the slices end at " + std::to_string(at) + " but feature_size is " +
                std::to_string(feature_size));
  }
  if (heading.start != root_position.stop()) {
    throw Error("feature layout: 'heading' " + bounds(heading) + " must directly follow 'root_position' " +
                bounds(root_position) + " (the root is position then heading)");
  }
  if (root().start != 0 && root().stop() != feature_size) {
    throw Error("feature layout: the root " + bounds(root()) +
                " must be at the start or the end of the frame, so the body is contiguous");
  }
}

FeatureSlice FeatureLayout::body() const {
  return root().start == 0 ? FeatureSlice{root().stop(), feature_size - root().stop()}
                           : FeatureSlice{0, root().start};
}

FeatureSlice FeatureLayout::rotation_6d_of(size_t joint) const {
  if (joint >= joint_count) throw Error("feature layout: joint " + std::to_string(joint) + " out of range");
  return {rotation_6d.start + 6 * joint, 6};
}

FeatureSlice FeatureLayout::joint_position_of(size_t joint) const {
  if (joint == 0 || joint >= joint_count) {
    throw Error("feature layout: joint_positions has joints 1.." + std::to_string(joint_count - 1) + ", not " +
                std::to_string(joint) + " (the root's position is root_position)");
  }
  return {joint_positions.start + 3 * (joint - 1), 3};
}

FeatureSlice FeatureLayout::joint_velocity_of(size_t joint) const {
  if (joint >= joint_count) throw Error("feature layout: joint " + std::to_string(joint) + " out of range");
  return {joint_velocities.start + 3 * joint, 3};
}

bool FeatureLayout::operator==(const FeatureLayout& o) const {
  return joint_count == o.joint_count && feature_size == o.feature_size && root_position == o.root_position &&
         heading == o.heading && rotation_6d == o.rotation_6d && joint_positions == o.joint_positions &&
         joint_velocities == o.joint_velocities && foot_contacts == o.foot_contacts;
}

// --- frames ----------------------------------------------------------------------

float MotionFrame::heading() const { return heading_angle(heading_cos, heading_sin); }

void pack_frame(const FeatureLayout& layout, const MotionFrame& frame, float* f) {
  const size_t j = layout.joint_count;
  if (frame.rotations.size() != j) throw Error(count_mismatch("pack_frame: rotations", frame.rotations.size(), j));
  if (frame.positions.size() != j) throw Error(count_mismatch("pack_frame: positions", frame.positions.size(), j));
  if (frame.velocities.size() != j) throw Error(count_mismatch("pack_frame: velocities", frame.velocities.size(), j));
  if (frame.contacts.size() != layout.contact_count()) {
    throw Error(count_mismatch("pack_frame: contacts", frame.contacts.size(), layout.contact_count()));
  }
  const glm::vec3& p = frame.root_position;
  float* root = f + layout.root_position.start;
  root[0] = p.x;
  root[1] = p.y;
  root[2] = p.z;
  f[layout.heading.start] = frame.heading_cos;
  f[layout.heading.start + 1] = frame.heading_sin;
  for (size_t joint = 0; joint < j; ++joint) {
    rotation_to_6d(frame.rotations[joint], f + layout.rotation_6d.start + 6 * joint);
    const glm::vec3& v = frame.velocities[joint];
    float* vel = f + layout.joint_velocities.start + 3 * joint;
    vel[0] = v.x;
    vel[1] = v.y;
    vel[2] = v.z;
  }
  for (size_t joint = 1; joint < j; ++joint) {
    const glm::vec3& q = frame.positions[joint];
    float* pos = f + layout.joint_positions.start + 3 * (joint - 1);
    pos[0] = q.x - p.x;
    pos[1] = q.y;
    pos[2] = q.z - p.z;
  }
  std::copy(frame.contacts.begin(), frame.contacts.end(), f + layout.foot_contacts.start);
}

void unpack_frame(const FeatureLayout& layout, const float* f, MotionFrame& frame) {
  const size_t j = layout.joint_count;
  const float* root = f + layout.root_position.start;
  frame.root_position = glm::vec3(root[0], root[1], root[2]);
  frame.heading_cos = f[layout.heading.start];
  frame.heading_sin = f[layout.heading.start + 1];
  frame.rotations.resize(j);
  frame.positions.resize(j);
  frame.velocities.resize(j);
  frame.positions[0] = frame.root_position;
  for (size_t joint = 0; joint < j; ++joint) {
    frame.rotations[joint] = rotation_from_6d(f + layout.rotation_6d.start + 6 * joint);
    const float* vel = f + layout.joint_velocities.start + 3 * joint;
    frame.velocities[joint] = glm::vec3(vel[0], vel[1], vel[2]);
  }
  for (size_t joint = 1; joint < j; ++joint) {
    const float* pos = f + layout.joint_positions.start + 3 * (joint - 1);
    frame.positions[joint] = glm::vec3(pos[0] + root[0], pos[1], pos[2] + root[2]);
  }
  frame.contacts.assign(f + layout.foot_contacts.start, f + layout.foot_contacts.stop());
}

MotionFrame unpack_frame(const FeatureLayout& layout, const float* features) {
  MotionFrame frame;
  unpack_frame(layout, features, frame);
  return frame;
}

// --- Normalization ---------------------------------------------------------------

Normalization::Normalization(std::vector<float> mean, std::vector<float> stddev, const std::string& what)
    : mean_(std::move(mean)), stddev_(std::move(stddev)) {
  if (mean_.empty()) throw Error(what + ": no statistics (empty mean)");
  if (mean_.size() != stddev_.size()) {
    throw Error(what + ": mean has " + std::to_string(mean_.size()) + " values but std has " +
                std::to_string(stddev_.size()));
  }
  for (size_t i = 0; i < mean_.size(); ++i) {
    if (!std::isfinite(mean_[i])) throw Error(what + ": mean[" + std::to_string(i) + "] is not finite");
    if (!std::isfinite(stddev_[i]) || !(stddev_[i] > 0.0f)) {
      throw Error(what + ": std[" + std::to_string(i) + "] is " + std::to_string(stddev_[i]) +
                  "; standard deviations must be finite and positive");
    }
  }
}

void Normalization::check_slice(FeatureSlice features) const {
  if (features.stop() > size()) {
    throw Error("normalization: features " + bounds(features) + " are outside the " + std::to_string(size()) +
                " statistics");
  }
}

void Normalization::normalize(float* data, size_t rows) const { normalize(data, rows, FeatureSlice{0, size()}); }

void Normalization::denormalize(float* data, size_t rows) const {
  denormalize(data, rows, FeatureSlice{0, size()});
}

void Normalization::normalize(float* data, size_t groups, FeatureSlice features) const {
  check_slice(features);
  for (size_t g = 0; g < groups; ++g) {
    float* row = data + g * features.size;
    for (size_t i = 0; i < features.size; ++i) {
      row[i] = (row[i] - mean_[features.start + i]) / stddev_[features.start + i];
    }
  }
}

void Normalization::denormalize(float* data, size_t groups, FeatureSlice features) const {
  check_slice(features);
  for (size_t g = 0; g < groups; ++g) {
    float* row = data + g * features.size;
    for (size_t i = 0; i < features.size; ++i) {
      row[i] = row[i] * stddev_[features.start + i] + mean_[features.start + i];
    }
  }
}

// --- patching ----------------------------------------------------------------------

std::vector<float> gather_root_tokens(const FeatureLayout& layout, const float* frames, size_t frame_count,
                                      size_t patch) {
  check_patch("gather_root_tokens", patch);
  if (frame_count % patch != 0) {
    throw Error("gather_root_tokens: " + std::to_string(frame_count) + " frames is not a multiple of the patch size " +
                std::to_string(patch));
  }
  const FeatureSlice root = layout.root();
  std::vector<float> out(frame_count * root.size);
  for (size_t f = 0; f < frame_count; ++f) {
    const float* src = frames + f * layout.feature_size + root.start;
    std::copy(src, src + root.size, out.begin() + static_cast<std::ptrdiff_t>(f * root.size));
  }
  return out;
}

void scatter_root_tokens(const FeatureLayout& layout, const float* root_tokens, size_t token_count, size_t patch,
                         float* frames) {
  check_patch("scatter_root_tokens", patch);
  const FeatureSlice root = layout.root();
  for (size_t f = 0; f < token_count * patch; ++f) {
    const float* src = root_tokens + f * root.size;
    std::copy(src, src + root.size, frames + f * layout.feature_size + root.start);
  }
}

std::vector<float> make_hybrid_tokens(const FeatureLayout& layout, const float* root_tokens, const float* latents,
                                      size_t count, size_t patch, size_t latent_size) {
  check_patch("make_hybrid_tokens", patch);
  const size_t root = patch * layout.root_size();
  const size_t token = root + latent_size;
  std::vector<float> out(count * token);
  for (size_t t = 0; t < count; ++t) {
    float* dst = out.data() + t * token;
    std::copy(root_tokens + t * root, root_tokens + (t + 1) * root, dst);
    std::copy(latents + t * latent_size, latents + (t + 1) * latent_size, dst + root);
  }
  return out;
}

void split_hybrid_tokens(const FeatureLayout& layout, const float* tokens, size_t count, size_t patch,
                         size_t latent_size, std::vector<float>& root_tokens, std::vector<float>& latents) {
  check_patch("split_hybrid_tokens", patch);
  const size_t root = patch * layout.root_size();
  const size_t token = root + latent_size;
  root_tokens.resize(count * root);
  latents.resize(count * latent_size);
  for (size_t t = 0; t < count; ++t) {
    const float* src = tokens + t * token;
    std::copy(src, src + root, root_tokens.begin() + static_cast<std::ptrdiff_t>(t * root));
    std::copy(src + root, src + token, latents.begin() + static_cast<std::ptrdiff_t>(t * latent_size));
  }
}

// --- re-centering --------------------------------------------------------------------

glm::vec3 planar_root_offset(const FeatureLayout& layout, const float* frames, size_t frame_count,
                             size_t anchor_frame) {
  if (anchor_frame >= frame_count) {
    throw Error("planar_root_offset: anchor frame " + std::to_string(anchor_frame) + " out of range (" +
                std::to_string(frame_count) + " frames)");
  }
  const float* p = frames + anchor_frame * layout.feature_size + layout.root_position.start;
  return glm::vec3(p[0], 0.0f, p[2]);
}

void recenter_frames(const FeatureLayout& layout, float* frames, size_t frame_count, const glm::vec3& offset) {
  shift_frames(layout, frames, frame_count, -offset.x, -offset.z);
}

void uncenter_frames(const FeatureLayout& layout, float* frames, size_t frame_count, const glm::vec3& offset) {
  shift_frames(layout, frames, frame_count, offset.x, offset.z);
}

void recenter_token_roots(const FeatureLayout& layout, float* tokens, size_t token_count, size_t token_size,
                          size_t patch, const glm::vec3& offset) {
  shift_token_roots(layout, tokens, token_count, token_size, patch, -offset.x, -offset.z, "recenter_token_roots");
}

void uncenter_token_roots(const FeatureLayout& layout, float* tokens, size_t token_count, size_t token_size,
                          size_t patch, const glm::vec3& offset) {
  shift_token_roots(layout, tokens, token_count, token_size, patch, offset.x, offset.z, "uncenter_token_roots");
}

}  // namespace ardy
