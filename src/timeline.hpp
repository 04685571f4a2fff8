#pragma once

// A JSON timeline of prompts and world-space constraints, the schema of
// export_tools/ardy_export/sampling/timeline.py (times in seconds, rounded to
// the nearest frame, ties to even, as Python's round):
//
//   {"prompts": [{"time": 0, "text": "a person walks"}, {"time": 4, "text": null}],
//    "constraints": [
//      {"type": "waypoint", "time": 3.0, "x": 1.0, "z": 4.0, "heading": 0.0},
//      {"type": "path", "start_time": 0.0, "points": [[0, 0], [0, 5]], "speed": 1.2, "heading": true},
//      {"type": "joint", "time": 2.0, "joint": "Hand_R", "position": [0.3, 1.5, 0.4]},
//      {"type": "contact", "start_time": 1.0, "end_time": 2.0, "feet": [0, 1], "value": 1}]}
//
// Also accepted (the frame-level forms of goldens.json and a few more):
// - "frame" instead of "time", "start_frame" / "end_frame" instead of
//   "start_time" / "end_time" (integers, model frames);
// - path with "positions" [[x, z], ...] (one per frame) and optional
//   "headings" instead of "points" and "speed";
// - {"type": "clicks", "points": ..., "speed": 1.2, "start_time": 0,
//   "smoothing_frames": 4}: mouse-style clicks -> smoothed dense path;
// - {"type": "keyframe", "time"|"frame", "features": [M values], "include_root": true};
// - joint "joint" as a name or an index, "rotation" as 3 rows of 3;
// - contact "feet" as indices or contact joint names (features.contact_joints).
//
// Times are 0..1e7 s and frames 0..1e7 * fps (a negative time is refused,
// not taken as "now"); positions, headings, speeds and contact values have
// the bounds of validate_constraint (constraints.hpp).
//
// Unknown types and fields, wrong value types, NaN/infinity and unknown
// joints are refused with an Error naming the entry and the field, e.g.
// "timeline.json: constraints[2] (joint): unknown joint 'Hand' (the
// skeleton's joints are Hips, Spine, ...)".

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "constraints.hpp"
#include "error.hpp"
#include "package.hpp"
#include "rollout.hpp"

namespace ardy {

struct Timeline {
  std::vector<PromptEvent> prompts;
  std::vector<Constraint> constraints;  // validated, in file order
};

// `source` names the timeline in errors. Prompts are checked with the
// package's text encoder rules (not empty, not too long, valid UTF-8).
Timeline parse_timeline(const nlohmann::json& document, const ModelPackage& package, const std::string& source);
Timeline parse_timeline_text(const std::string& json_text, const ModelPackage& package, const std::string& source);

// The timeline as a JSON document parse_timeline reads back to the same
// timeline (frame-level forms: "frame", "start_frame", dense path
// "positions"; joints and feet by name; numbers at full double precision).
nlohmann::json timeline_to_json(const Timeline& timeline, const ModelPackage& package);

// Seconds -> model frame: round(seconds * fps), ties to even. Error for a
// non-finite or out-of-range time.
int64_t seconds_to_frame(double seconds, double fps);

}  // namespace ardy
