#include "timeline.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "json_text.hpp"

namespace ardy {
namespace {

using json = nlohmann::json;

constexpr double kMaxSeconds = 1e7;  // about 116 days; timeline times are 0..kMaxSeconds

// The fields of one JSON object, with errors that name the entry and field.
class Fields {
 public:
  Fields(const json& object, std::string where, double fps) : object_(object), where_(std::move(where)), fps_(fps) {
    if (!object_.is_object()) throw Error(where_ + ": must be an object, found " + describe_json(object_));
  }

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw Error(where_ + ": " + field + " " + what);
  }
  const std::string& where() const { return where_; }

  void allow(std::initializer_list<const char*> keys) const {
    for (auto it = object_.begin(); it != object_.end(); ++it) {
      const bool known = std::any_of(keys.begin(), keys.end(), [&](const char* k) { return it.key() == k; });
      if (!known) {
        std::string names;
        for (const char* k : keys) names += std::string(names.empty() ? "" : ", ") + k;
        throw Error(where_ + ": unknown field '" + it.key() + "' (expected " + names + ")");
      }
    }
  }
  // Present and not null.
  bool has(const char* key) const {
    const auto it = object_.find(key);
    return it != object_.end() && !it->is_null();
  }
  const json& at(const char* key) const {
    const auto it = object_.find(key);
    if (it == object_.end() || it->is_null()) throw Error(where_ + ": missing field '" + key + "'");
    return *it;
  }
  double number(const json& value, const std::string& field) const {
    if (!value.is_number()) fail(field, "must be a number, found " + describe_json(value));
    const double v = value.get<double>();
    if (!std::isfinite(v)) fail(field, "must be finite, found " + describe_json(value));
    return v;
  }
  double number(const char* key) const { return number(at(key), key); }
  double number_or(const char* key, double fallback) const { return has(key) ? number(key) : fallback; }
  int64_t integer(const json& value, const std::string& field) const {
    if (!value.is_number_integer()) fail(field, "must be an integer, found " + describe_json(value));
    if (value.is_number_unsigned() && value.get<uint64_t>() > uint64_t(std::numeric_limits<int64_t>::max())) fail(field, "is too large");
    return value.get<int64_t>();
  }
  bool boolean_or(const char* key, bool fallback) const {
    if (!has(key)) return fallback;
    const json& value = at(key);
    if (!value.is_boolean()) fail(key, "must be true or false, found " + describe_json(value));
    return value.get<bool>();
  }
  // A frame from "<frame_key>" (integer) or "<time_key>" (seconds).
  int64_t frame(const char* frame_key, const char* time_key, std::optional<int64_t> fallback = std::nullopt) const {
    const bool by_frame = has(frame_key), by_time = has(time_key);
    if (by_frame && by_time) {
      fail(frame_key, std::string("and ") + time_key + " are both given (expected one of them)");
    }
    // A timeline starts at 0: an earlier time is a mistake, not "now".
    if (by_frame) {
      const int64_t f = integer(at(frame_key), frame_key);
      const int64_t last = static_cast<int64_t>(kMaxSeconds * fps_);
      if (f < 0 || f > last) {
        fail(frame_key, "is " + std::to_string(f) + ", expected 0.." + std::to_string(last) + " (0 to 1e7 s)");
      }
      return f;
    }
    if (by_time) {
      const double seconds = number(time_key);
      if (seconds < 0.0 || seconds > kMaxSeconds) {
        std::ostringstream text;
        text << seconds;
        fail(time_key, "is " + text.str() + " s, expected 0..1e7 s (timelines start at 0)");
      }
      try {
        return seconds_to_frame(seconds, fps_);
      } catch (const Error& e) {
        fail(time_key, e.what());
      }
    }
    if (fallback) return *fallback;
    throw Error(where_ + ": missing field '" + time_key + "' (or '" + frame_key + "')");
  }
  std::vector<glm::dvec2> points(const char* key) const {
    const json& list = at(key);
    if (!list.is_array()) fail(key, "must be an array of [x, z] pairs, found " + describe_json(list));
    std::vector<glm::dvec2> out;
    out.reserve(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string field = std::string(key) + "[" + std::to_string(i) + "]";
      const json& p = list[i];
      if (!p.is_array() || p.size() != 2) fail(field, "must be [x, z], found " + describe_json(p));
      out.emplace_back(number(p[0], field + "[0]"), number(p[1], field + "[1]"));
    }
    return out;
  }
  std::vector<double> numbers(const char* key) const {
    const json& list = at(key);
    if (!list.is_array()) fail(key, "must be an array of numbers, found " + describe_json(list));
    std::vector<double> out;
    out.reserve(list.size());
    for (size_t i = 0; i < list.size(); ++i)
      out.push_back(number(list[i], std::string(key) + "[" + std::to_string(i) + "]"));
    return out;
  }
  glm::dvec3 vec3(const char* key) const {
    const std::vector<double> v = numbers(key);
    if (v.size() != 3) fail(key, "must be [x, y, z], found " + describe_json(at(key)));
    return glm::dvec3(v[0], v[1], v[2]);
  }
  // 3 rows of 3 (row-major, as numpy writes a matrix) -> GLM (column-major).
  glm::dmat3 mat3(const char* key) const {
    const json& rows = at(key);
    if (!rows.is_array() || rows.size() != 3) fail(key, "must be 3 rows of 3 numbers, found " + describe_json(rows));
    glm::dmat3 m(1.0);
    for (int r = 0; r < 3; ++r) {
      const std::string field = std::string(key) + "[" + std::to_string(r) + "]";
      if (!rows[r].is_array() || rows[r].size() != 3)
        fail(field, "must be a row of 3 numbers, found " + describe_json(rows[r]));
      for (int c = 0; c < 3; ++c) m[c][r] = number(rows[r][c], field + "[" + std::to_string(c) + "]");
    }
    return m;
  }

 private:
  const json& object_;
  std::string where_;
  double fps_;
};

Constraint parse_constraint(const json& entry, size_t index, const ModelPackage& package, const std::string& source) {
  const double fps = package.fps();
  const std::string base = source + ": constraints[" + std::to_string(index) + "]";
  if (!entry.is_object()) throw Error(base + ": must be an object, found " + describe_json(entry));
  const auto type_it = entry.find("type");
  if (type_it == entry.end() || !type_it->is_string()) {
    throw Error(base + ": missing or non-string field 'type' (waypoint, path, clicks, keyframe, joint or contact)");
  }
  const std::string type = type_it->get<std::string>();
  const Fields f(entry, base + " (" + type + ")", fps);
  if (type == "waypoint") {
    f.allow({"type", "time", "frame", "x", "z", "heading"});
    RootWaypoint c;
    c.frame = f.frame("frame", "time");
    c.x = f.number("x");
    c.z = f.number("z");
    if (f.has("heading")) c.heading = f.number("heading");
    return c;
  }
  if (type == "path") {
    f.allow({"type", "start_time", "start_frame", "points", "speed", "heading", "positions", "headings"});
    const int64_t start = f.frame("start_frame", "start_time", int64_t{0});
    if (f.has("positions")) {
      if (f.has("points") || f.has("speed")) {
        f.fail("positions", "and points/speed are both given (a path is either dense positions or a polyline)");
      }
      if (entry.contains("heading"))
        f.fail("heading", "applies to a polyline path (points), not to positions; use headings");
      RootPath c;
      c.start_frame = start;
      c.positions = f.points("positions");
      if (f.has("headings")) c.headings = f.numbers("headings");
      return c;
    }
    if (f.has("headings")) f.fail("headings", "applies to dense positions, not to a polyline path (points)");
    const std::vector<glm::dvec2> points = f.points("points");
    const double speed = f.number_or("speed", 1.2);
    try {
      return path_from_polyline(points, speed, start, fps, f.boolean_or("heading", true));
    } catch (const Error& e) {
      throw Error(f.where() + ": " + e.what());
    }
  }
  if (type == "clicks") {
    f.allow({"type", "start_time", "start_frame", "points", "speed", "smoothing_frames"});
    const int64_t start = f.frame("start_frame", "start_time", int64_t{0});
    const std::vector<glm::dvec2> points = f.points("points");
    const double speed = f.number_or("speed", 1.2);
    int64_t smoothing = 4;
    if (f.has("smoothing_frames")) {
      smoothing = f.integer(f.at("smoothing_frames"), "smoothing_frames");
      if (smoothing < 0 || smoothing > 1000) f.fail("smoothing_frames", "must be in 0..1000");
    }
    try {
      return path_from_clicks(points, speed, start, fps, static_cast<size_t>(smoothing));
    } catch (const Error& e) {
      throw Error(f.where() + ": " + e.what());
    }
  }
  if (type == "keyframe") {
    f.allow({"type", "time", "frame", "features", "include_root"});
    PoseKeyframe c;
    c.frame = f.frame("frame", "time");
    c.features = f.numbers("features");
    c.include_root = f.boolean_or("include_root", true);
    return c;
  }
  if (type == "joint") {
    f.allow({"type", "time", "frame", "joint", "position", "rotation"});
    JointTarget c;
    c.frame = f.frame("frame", "time");
    const json& joint = f.at("joint");
    if (joint.is_string()) {
      try {
        c.joint = joint_index(package.skeleton(), joint.get<std::string>());
      } catch (const Error& e) {
        throw Error(f.where() + ": " + e.what());
      }
    } else {
      const int64_t index = f.integer(joint, "joint");
      const size_t count = package.skeleton().joint_count();
      if (index < 0 || index >= static_cast<int64_t>(count)) {
        f.fail("joint",
               "is " + std::to_string(index) + ", expected a joint name or an index 0.." + std::to_string(count - 1));
      }
      c.joint = static_cast<size_t>(index);
    }
    if (f.has("position")) c.position = f.vec3("position");
    if (f.has("rotation")) c.rotation = f.mat3("rotation");
    if (!c.position && !c.rotation) f.fail("position", "and rotation are both missing (a joint target needs one)");
    return c;
  }
  if (type == "contact") {
    f.allow({"type", "start_time", "end_time", "start_frame", "end_frame", "feet", "value"});
    FootContact c;
    c.start_frame = f.frame("start_frame", "start_time");
    c.end_frame = f.frame("end_frame", "end_time");
    if (f.has("feet")) {
      const json& feet = f.at("feet");
      if (!feet.is_array() || feet.empty()) f.fail("feet", "must be a non-empty array, found " + describe_json(feet));
      const std::vector<std::string>& names = package.contact_joints();
      for (size_t i = 0; i < feet.size(); ++i) {
        const std::string field = "feet[" + std::to_string(i) + "]";
        if (feet[i].is_string()) {
          const auto it = std::find(names.begin(), names.end(), feet[i].get<std::string>());
          if (it == names.end()) {
            std::string known;
            for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
            f.fail(field, "is '" + feet[i].get<std::string>() + "', not a contact joint (" + known + ")");
          }
          c.feet.push_back(static_cast<size_t>(it - names.begin()));
        } else {
          const int64_t foot = f.integer(feet[i], field);
          if (foot < 0 || foot >= static_cast<int64_t>(names.size())) {
            f.fail(field, "is " + std::to_string(foot) + ", expected 0.." + std::to_string(names.size() - 1));
          }
          c.feet.push_back(static_cast<size_t>(foot));
        }
      }
    }
    c.value = f.number_or("value", 1.0);
    return c;
  }
  throw Error(base + ": unknown type '" + type + "' (expected waypoint, path, clicks, keyframe, joint or contact)");
}

}  // namespace

int64_t seconds_to_frame(double seconds, double fps) {
  if (!std::isfinite(seconds) || std::fabs(seconds) > kMaxSeconds) {
    throw Error("time " + std::to_string(seconds) + " s is not a finite time within +-1e7 s");
  }
  return static_cast<int64_t>(std::nearbyint(seconds * fps));
}

Timeline parse_timeline(const json& document, const ModelPackage& package, const std::string& source) {
  const Fields top(document, source, package.fps());
  top.allow({"prompts", "constraints", "comment", "description"});
  Timeline out;
  if (top.has("prompts")) {
    const json& prompts = top.at("prompts");
    if (!prompts.is_array()) top.fail("prompts", "must be an array, found " + describe_json(prompts));
    for (size_t i = 0; i < prompts.size(); ++i) {
      const Fields p(prompts[i], source + ": prompts[" + std::to_string(i) + "]", package.fps());
      p.allow({"time", "frame", "text"});
      PromptEvent event;
      event.frame = p.frame("frame", "time", int64_t{0});
      if (!prompts[i].contains("text"))
        throw Error(p.where() + ": missing field 'text' (a string, or null for no prompt)");
      if (p.has("text")) {
        const json& text = p.at("text");
        if (!text.is_string()) p.fail("text", "must be a string or null, found " + describe_json(text));
        event.text = text.get<std::string>();
        try {
          package.text_encoder().normalize_prompt(*event.text);
        } catch (const Error& e) {
          throw Error(p.where() + ": text: " + e.what());
        }
      }
      out.prompts.push_back(std::move(event));
    }
  }
  if (top.has("constraints")) {
    const json& constraints = top.at("constraints");
    if (!constraints.is_array()) top.fail("constraints", "must be an array, found " + describe_json(constraints));
    for (size_t i = 0; i < constraints.size(); ++i) {
      Constraint c = parse_constraint(constraints[i], i, package, source);
      validate_constraint(c, package.layout(), source + ": constraints[" + std::to_string(i) + "]");
      out.constraints.push_back(std::move(c));
    }
  }
  return out;
}

json timeline_to_json(const Timeline& timeline, const ModelPackage& package) {
  json prompts = json::array();
  for (const PromptEvent& event : timeline.prompts) {
    prompts.push_back({{"frame", event.frame}, {"text", event.text ? json(*event.text) : json()}});
  }
  const auto pair = [](const glm::dvec2& v) { return json::array({v.x, v.y}); };
  json constraints = json::array();
  for (const Constraint& constraint : timeline.constraints) {
    json entry;
    if (const auto* waypoint = std::get_if<RootWaypoint>(&constraint)) {
      entry = {{"type", "waypoint"}, {"frame", waypoint->frame}, {"x", waypoint->x}, {"z", waypoint->z}};
      if (waypoint->heading) entry["heading"] = *waypoint->heading;
    } else if (const auto* path = std::get_if<RootPath>(&constraint)) {
      json positions = json::array();
      for (const glm::dvec2& position : path->positions) positions.push_back(pair(position));
      entry = {{"type", "path"}, {"start_frame", path->start_frame}, {"positions", std::move(positions)}};
      if (!path->headings.empty()) entry["headings"] = path->headings;
    } else if (const auto* keyframe = std::get_if<PoseKeyframe>(&constraint)) {
      entry = {{"type", "keyframe"},
               {"frame", keyframe->frame},
               {"features", keyframe->features},
               {"include_root", keyframe->include_root}};
    } else if (const auto* target = std::get_if<JointTarget>(&constraint)) {
      entry = {{"type", "joint"}, {"frame", target->frame}, {"joint", package.skeleton().name(target->joint)}};
      if (target->position) entry["position"] = {target->position->x, target->position->y, target->position->z};
      if (target->rotation) {
        const glm::dmat3& m = *target->rotation;
        json rows = json::array();
        for (int r = 0; r < 3; ++r) rows.push_back({m[0][r], m[1][r], m[2][r]});
        entry["rotation"] = std::move(rows);
      }
    } else if (const auto* contact = std::get_if<FootContact>(&constraint)) {
      json feet = json::array();
      for (size_t foot : contact->feet) feet.push_back(package.contact_joints().at(foot));
      entry = {{"type", "contact"},
               {"start_frame", contact->start_frame},
               {"end_frame", contact->end_frame},
               {"value", contact->value}};
      if (!feet.empty()) entry["feet"] = std::move(feet);
    }
    constraints.push_back(std::move(entry));
  }
  return {{"prompts", std::move(prompts)}, {"constraints", std::move(constraints)}};
}

Timeline parse_timeline_text(const std::string& json_text, const ModelPackage& package, const std::string& source) {
  json document;
  try {
    document = json::parse(json_text);
  } catch (const json::exception& e) {
    throw Error(source + ": not valid JSON (" + e.what() + ")");
  }
  return parse_timeline(document, package, source);
}

}  // namespace ardy
