#include "motion_generator.hpp"

#include "motion_goals.hpp"
#include "motion_pose_modifier.hpp"

#include "godot/error_macros.hpp"
#include "godot/ref.hpp"

#include "bvh.hpp"
#include "features.hpp"
#include "generation_cpu.hpp"
#include "kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <thread>

#include <nlohmann/json.hpp>

using namespace godot;

namespace ardy {

namespace {

constexpr size_t kMaxPromptChars = 2000;
constexpr size_t kLatencySamples = 64;
// Re-anchoring: goals are sent again once the body has drifted this far from
// where the motion put it, at most this often.
constexpr float kResubmitDrift = 0.1f;
constexpr double kResubmitInterval = 0.25;
// Height of a posed character's lowest joint (a toe) above the ground.
constexpr float kGroundClearance = 0.03f;

using Clock = std::chrono::steady_clock;

std::string text(const String &value) {
	return value.utf8();
}

bool finite(const Vector3 &v) {
	return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Adds the elapsed microseconds of one main-thread step to `total`.
class MainThreadTimer {
public:
	explicit MainThreadTimer(double &total) : total_(total), start_(Clock::now()) {}
	~MainThreadTimer() { total_ += std::chrono::duration<double, std::micro>(Clock::now() - start_).count(); }

private:
	double &total_;
	Clock::time_point start_;
};

double median(std::vector<double> values) {
	if (values.empty()) {
		return 0.0;
	}
	std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
	return values[values.size() / 2];
}

} // namespace

MotionGenerator::MotionGenerator() : model_path_(kDefaultModelPath), in_editor_(Engine::get_singleton()->is_editor_hint()) {}

MotionGenerator::~MotionGenerator() = default;

// --- properties --------------------------------------------------------------

void MotionGenerator::set_model_path(const String &path) {
	if (path == model_path_) {
		return;
	}
	// The current model keeps animating until the new one has loaded.
	model_path_ = path;
	pending_model_.reset();
	if (is_inside_tree()) {
		request_model();
	}
	update_configuration_warnings();
}

String MotionGenerator::get_model_path() const {
	return model_path_;
}

void MotionGenerator::set_skeleton(const NodePath &path) {
	skeleton_path_ = path;
	skeleton_cache_id_ = 0;
	remove_modifier();
	retargeter_.reset();
	rig_skeleton_id_ = 0;
	update_configuration_warnings();
}

NodePath MotionGenerator::get_skeleton() const {
	return skeleton_path_;
}

void MotionGenerator::set_bone_map(const Ref<BoneMap> &bone_map) {
	bone_map_ = bone_map;
	retargeter_.reset();
	update_configuration_warnings();
}

Ref<BoneMap> MotionGenerator::get_bone_map() const {
	return bone_map_;
}

void MotionGenerator::set_root_motion_target(const NodePath &path) {
	root_motion_target_path_ = path;
	target_cache_id_ = 0;
	has_last_character_ = false;
	update_configuration_warnings();
}

NodePath MotionGenerator::get_root_motion_target() const {
	return root_motion_target_path_;
}

void MotionGenerator::set_influence(double influence) {
	influence_ = std::clamp(std::isfinite(influence) ? influence : 1.0, 0.0, 1.0);
	if (auto *modifier = Object::cast_to<MotionPoseModifier>(object_from_instance_id(modifier_id_))) {
		modifier->set_influence(influence_);
	}
}

double MotionGenerator::get_influence() const {
	return influence_;
}

void MotionGenerator::set_prompt(const String &prompt) {
	const std::string value = text(prompt);
	if (value.size() > kMaxPromptChars) {
		fail("prompt: " + std::to_string(value.size()) + " characters, at most " + std::to_string(kMaxPromptChars));
		return;
	}
	prompt_ = prompt;
	if (!planner_) {
		return;
	}
	try {
		if (value.empty()) {
			planner_->clear_prompt();
		} else {
			planner_->set_prompt(value);
		}
	} catch (const std::exception &failure) {
		fail(std::string("prompt: ") + failure.what());
	}
}

String MotionGenerator::get_prompt() const {
	return prompt_;
}

void MotionGenerator::set_playing(bool playing) {
	playing_ = playing;
	if (playing_ && is_inside_tree()) {
		request_model();
	}
}

bool MotionGenerator::is_playing() const {
	return playing_;
}

void MotionGenerator::set_steps(int64_t steps) {
	if (steps < 0 || steps > 1000) {
		fail("steps: " + std::to_string(steps) + " is out of range (0 for the model's default, or 1..1000)");
		return;
	}
	const int64_t previous = steps_;
	steps_ = steps;
	if (!apply_sampling("steps")) {
		steps_ = previous;
	}
}

// The sampling settings as the properties say, the model's defaults where
// they ask for them (0 steps, a negative weight), for the windows to come.
bool MotionGenerator::apply_sampling(const char *what) {
	if (!planner_ || !package_) {
		return true;
	}
	const SamplingDefaults &defaults = package_->sampling_defaults();
	try {
		planner_->set_sampling(steps_ > 0 ? static_cast<size_t>(steps_) : defaults.steps,
				text_guidance_ >= 0.0 ? static_cast<float>(text_guidance_) : defaults.w_text,
				constraint_guidance_ >= 0.0 ? static_cast<float>(constraint_guidance_) : defaults.w_con,
				path_guidance_scale_ >= 0.0 ? static_cast<float>(path_guidance_scale_) : defaults.path_guidance_scale,
				text_only_guidance_scale_ >= 0.0 ? static_cast<float>(text_only_guidance_scale_) : defaults.text_only_guidance_scale);
	} catch (const std::exception &failure) {
		return fail(std::string(what) + ": " + failure.what());
	}
	return true;
}

// Sets one sampling weight for the windows to come; the previous value stays if the planner
// refuses it.
void MotionGenerator::change_sampling(double &field, double value, const char *what) {
	const double previous = field;
	field = value;
	if (!apply_sampling(what)) {
		field = previous;
	}
}

int64_t MotionGenerator::get_steps() const {
	return steps_;
}

void MotionGenerator::set_text_guidance(double weight) {
	if (!std::isfinite(weight)) {
		fail("text_guidance: not a finite number");
		return;
	}
	change_sampling(text_guidance_, weight, "text_guidance");
}

double MotionGenerator::get_text_guidance() const {
	return text_guidance_;
}

void MotionGenerator::set_constraint_guidance(double weight) {
	if (!std::isfinite(weight)) {
		fail("constraint_guidance: not a finite number");
		return;
	}
	change_sampling(constraint_guidance_, weight, "constraint_guidance");
}

double MotionGenerator::get_constraint_guidance() const {
	return constraint_guidance_;
}

void MotionGenerator::set_path_guidance_scale(double scale) {
	if (!(scale < 0.0 || ardy::path_guidance_scale_in_range(scale))) {
		fail("path_guidance_scale: " + std::to_string(scale) + " is out of range (negative for the model's default, or above 0 up to 1)");
		return;
	}
	change_sampling(path_guidance_scale_, scale, "path_guidance_scale");
}

double MotionGenerator::get_path_guidance_scale() const {
	return path_guidance_scale_;
}

void MotionGenerator::set_text_only_guidance_scale(double scale) {
	if (!(scale < 0.0 || ardy::text_only_guidance_scale_in_range(scale))) {
		fail("text_only_guidance_scale: " + std::to_string(scale) + " is out of range (negative for the model's default, or above 0 up to 4)");
		return;
	}
	change_sampling(text_only_guidance_scale_, scale, "text_only_guidance_scale");
}

double MotionGenerator::get_text_only_guidance_scale() const {
	return text_only_guidance_scale_;
}

void MotionGenerator::set_seed(int64_t seed) {
	seed_ = seed;
}

int64_t MotionGenerator::get_seed() const {
	return seed_;
}

void MotionGenerator::set_history_seconds(double seconds) {
	if (!std::isfinite(seconds) || seconds < 0.0 || seconds > 8.0) {
		fail("history_seconds: " + std::to_string(seconds) + " is out of range (0..8 seconds)");
		return;
	}
	history_seconds_ = seconds;
}

double MotionGenerator::get_history_seconds() const {
	return history_seconds_;
}

void MotionGenerator::set_replan_buffer_frames(int64_t frames) {
	if (frames < 0 || frames > 400) {
		fail("replan_buffer_frames: " + std::to_string(frames) + " is out of range (0..400 frames)");
		return;
	}
	replan_buffer_frames_ = frames;
}

int64_t MotionGenerator::get_replan_buffer_frames() const {
	return replan_buffer_frames_;
}

void MotionGenerator::set_foot_lock(bool enabled) {
	foot_lock_ = enabled;
}

bool MotionGenerator::get_foot_lock() const {
	return foot_lock_;
}

void MotionGenerator::set_velocity_blend_seconds(double seconds) {
	if (!std::isfinite(seconds) || seconds <= 0.0 || seconds > 10.0) {
		fail("velocity_blend_seconds: " + std::to_string(seconds) + " is out of range (more than 0, at most 10 seconds)");
		return;
	}
	velocity_blend_seconds_ = seconds;
}

double MotionGenerator::get_velocity_blend_seconds() const {
	return velocity_blend_seconds_;
}

void MotionGenerator::set_shared_inference(bool shared) {
	shared_inference_ = shared;
}

bool MotionGenerator::get_shared_inference() const {
	return shared_inference_;
}

void MotionGenerator::set_target_velocity(const Vector3 &velocity) {
	if (!finite(velocity)) {
		fail("target_velocity: not a finite vector");
		return;
	}
	target_velocity_ = velocity;
	if (!planner_) {
		return;
	}
	const glm::vec3 world(velocity.x, 0.0f, velocity.z);
	if (glm::length(world) < 1e-6f) {
		planner_->clear_target_velocity();
		return;
	}
	const glm::vec3 model = glm::transpose(anchor_.yaw) * world / anchor_.scale;
	try {
		planner_->set_target_velocity(model.x, model.z);
	} catch (const std::exception &failure) {
		fail(std::string("target_velocity: ") + failure.what());
	}
}

Vector3 MotionGenerator::get_target_velocity() const {
	return target_velocity_;
}

void MotionGenerator::set_waypoint_reach_distance(double metres) {
	if (!std::isfinite(metres) || metres <= 0.0) {
		fail("waypoint_reach_distance: expected a finite distance > 0 (metres)");
		return;
	}
	waypoint_reach_distance_ = metres;
}

double MotionGenerator::get_waypoint_reach_distance() const {
	return waypoint_reach_distance_;
}

void MotionGenerator::set_preview_in_editor(bool preview) {
	preview_in_editor_ = preview;
	if (!in_editor_) {
		return;
	}
	if (preview_in_editor_ && is_inside_tree()) {
		request_model();
	} else if (!preview_in_editor_) {
		stop_planner();
		remove_modifier();
		showing_clip_ = false;  // the clip is kept; seek_clip shows it again
	}
}

bool MotionGenerator::get_preview_in_editor() const {
	return preview_in_editor_;
}

// --- goals ---------------------------------------------------------------------

double MotionGenerator::check_time(double at_seconds, const char *what) const {
	if (!std::isfinite(at_seconds)) {
		throw Error(std::string(what) + ": at_seconds is not a finite number");
	}
	const double now = get_time();
	if (at_seconds < now - 1e-6) {
		throw Error(std::string(what) + ": at_seconds " + std::to_string(at_seconds) + " is in the past (get_time() is " + std::to_string(now) + ")");
	}
	if (at_seconds > now + 3600.0) {
		throw Error(std::string(what) + ": at_seconds " + std::to_string(at_seconds) + " is more than an hour ahead");
	}
	return at_seconds;
}

void MotionGenerator::queue_prompt(const String &prompt, double at_seconds) {
	const std::string value = text(prompt);
	try {
		check_time(at_seconds, "queue_prompt");
		if (value.empty() || value.size() > kMaxPromptChars) {
			throw Error("queue_prompt: text has " + std::to_string(value.size()) + " characters, expected 1.." + std::to_string(kMaxPromptChars));
		}
		if (planner_) {
			planner_->set_prompt_at(at_seconds, value);
		} else {
			queued_prompts_.push_back({ at_seconds, value });
		}
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

void MotionGenerator::clear_prompts() {
	prompt_ = String();
	queued_prompts_.clear();
	if (planner_) {
		planner_->reset_prompts_at(planner_->time(), std::nullopt);
	}
}

void MotionGenerator::submit(WorldWaypoint &waypoint) {
	const glm::vec3 model = anchor_.to_model(waypoint.position);
	std::optional<double> heading;
	if (waypoint.heading) {
		heading = *waypoint.heading - anchor_.yaw_angle;
	}
	waypoint.id = planner_->add_waypoint(std::max(waypoint.time, planner_->time()), model.x, model.z, heading);
}

void MotionGenerator::add_waypoint(const Vector3 &position, double at_seconds, double heading) {
	try {
		check_time(at_seconds, "add_waypoint");
		if (!finite(position)) {
			throw Error("add_waypoint: position is not a finite vector");
		}
		if (std::isinf(heading)) {
			throw Error("add_waypoint: heading is infinite (NAN for none, or radians)");
		}
		WorldWaypoint waypoint;
		waypoint.position = to_glm(position);
		waypoint.time = at_seconds;
		if (!std::isnan(heading)) {
			waypoint.heading = heading;
		}
		if (planner_) {
			submit(waypoint);
		}
		waypoints_.push_back(waypoint);
		MotionWaypoint *resource = memnew_object<MotionWaypoint>();
		resource->set_position(position);
		resource->set_time(at_seconds);
		resource->set_use_heading(waypoint.heading.has_value());
		resource->set_heading(waypoint.heading.value_or(0.0));
		waypoint_resources_.push_back(Variant(resource));
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

template <class Goal>
void MotionGenerator::replace_goals(std::vector<Goal> &goals, std::vector<Goal> replacement) {
	if (planner_) {
		for (const Goal &goal : goals) {
			planner_->remove_constraint(goal.id);
		}
	}
	goals = std::move(replacement);
	if (!planner_) {
		return;  // sent when generation starts
	}
	const double now = get_time();
	for (Goal &goal : goals) {
		if (goal.time >= now) {
			submit(goal);
		}
	}
}

void MotionGenerator::set_waypoints(const Array &waypoints) {
	try {
		std::vector<WorldWaypoint> list;
		for (int64_t i = 0; i < waypoints.size(); ++i) {
			auto *resource = object_from_owner<MotionWaypoint>(waypoints[i].object_ptr());
			if (resource == nullptr) {
				throw Error("waypoints: entry " + std::to_string(i) + " is not a MotionWaypoint");
			}
			const Vector3 position = resource->get_position();
			if (!finite(position) || !std::isfinite(resource->get_time()) || !std::isfinite(resource->get_heading())) {
				throw Error("waypoints: entry " + std::to_string(i) + " has a position, time or heading that is not finite");
			}
			WorldWaypoint waypoint;
			waypoint.position = to_glm(position);
			waypoint.time = resource->get_time();
			if (resource->get_use_heading()) {
				waypoint.heading = resource->get_heading();
			}
			list.push_back(waypoint);
		}
		replace_goals(waypoints_, std::move(list));
		waypoint_resources_ = waypoints;
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

Array MotionGenerator::get_waypoints() const {
	return waypoint_resources_;
}

void MotionGenerator::clear_waypoints() {
	if (planner_) {
		for (const WorldWaypoint &waypoint : waypoints_) {
			planner_->remove_constraint(waypoint.id);
		}
		if (path_) {
			planner_->remove_constraint(path_->id);
		}
	}
	waypoints_.clear();
	waypoint_resources_ = Array();
	path_.reset();
}

void MotionGenerator::submit(WorldPath &path) {
	std::vector<glm::dvec2> points;
	points.reserve(path.points.size());
	for (const glm::vec3 &point : path.points) {
		const glm::vec3 model = anchor_.to_model(point);
		points.emplace_back(model.x, model.z);
	}
	path.id = planner_->add_path(std::max(path.start_time, planner_->time()), points, path.speed / anchor_.scale, false);
}

void MotionGenerator::set_path(const Variant &path, double speed) {
	try {
		if (!std::isfinite(speed) || speed <= 0.0 || speed > 10.0) {
			throw Error("set_path: speed " + std::to_string(speed) + " is out of range (more than 0, at most 10 m/s)");
		}
		WorldPath world;
		PackedVector3Array points;
		Frame to_world;
		if (path.get_type() == Variant::PACKED_VECTOR3_ARRAY) {
			points = path;
		} else if (auto *path_node = object_from_owner<Path3D>(path.object_ptr())) {
			Ref<Curve3D> curve = path_node->get_curve();
			if (curve.is_null()) {
				throw Error("set_path: the Path3D has no curve");
			}
			points = curve->get_baked_points();
			to_world = to_frame(path_node->get_global_transform());
		} else if (auto *curve = object_from_owner<Curve3D>(path.object_ptr())) {
			points = curve->get_baked_points();
		} else {
			throw Error("set_path: path must be a Curve3D, a Path3D or a PackedVector3Array");
		}
		if (points.size() < 2) {
			throw Error("set_path: the path has " + std::to_string(points.size()) + " points, at least 2 are needed");
		}
		for (int64_t i = 0; i < points.size(); ++i) {
			if (!finite(points[i])) {
				throw Error("set_path: point " + std::to_string(i) + " is not a finite vector");
			}
			world.points.push_back(to_world.apply(to_glm(points[i])));
		}
		world.start_time = get_time();
		world.speed = speed;
		if (planner_) {
			if (path_) {
				planner_->remove_constraint(path_->id);
			}
			submit(world);
		}
		path_ = std::move(world);
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

std::optional<std::string> MotionGenerator::model_joint_of(const String &bone) const {
	const std::string name = text(bone);
	if (!package_) {
		return std::nullopt;
	}
	const Skeleton &skeleton = package_->skeleton();
	if (skeleton.find(name)) {
		return name;
	}
	if (retargeter_) {
		Skeleton3D *rig = find_skeleton();
		const int32_t rig_bone = rig != nullptr ? rig->find_bone(bone) : -1;
		for (size_t joint = 0; joint < skeleton.joint_count(); ++joint) {
			if (rig_bone >= 0 && retargeter_->bone_of_joint()[joint] == rig_bone) {
				return skeleton.name(joint);
			}
		}
	}
	return std::nullopt;
}

void MotionGenerator::submit(WorldJointTarget &target) {
	JointTargetSpec spec;
	spec.time = std::max(target.time, planner_->time());
	spec.joint = target.joint;
	if (target.position) {
		const glm::vec3 model = anchor_.to_model(*target.position);
		spec.position = glm::dvec3(model);
		// Where the root will be then, as far as the queue knows.
		Pose then;
		if (planner_->sample(spec.time, then)) {
			spec.root_xz = glm::dvec2(then.root_position.x, then.root_position.z);
		} else {
			spec.root_xz = glm::dvec2(0.0);
		}
	}
	if (target.rotation) {
		spec.rotation = glm::dquat(*target.rotation);
	}
	target.id = planner_->add_joint_target(spec);
}

void MotionGenerator::add_joint_target(const String &bone, double at_seconds, const Variant &position, const Variant &rotation) {
	try {
		check_time(at_seconds, "add_joint_target");
		if (!planner_ || !retargeter_) {
			throw Error("add_joint_target: nothing is generating yet (wait for model_loaded and set playing)");
		}
		const std::optional<std::string> joint = model_joint_of(bone);
		if (!joint) {
			throw Error("add_joint_target: unknown bone '" + text(bone) + "' (a bone of the skeleton mapped to the model, or a model joint: " +
					text(String(package_->skeleton().names().front())) + ", ...)");
		}
		WorldJointTarget target;
		target.joint = *joint;
		target.time = at_seconds;
		if (position.get_type() == Variant::VECTOR3) {
			const Vector3 value = position;
			if (!finite(value)) {
				throw Error("add_joint_target: position is not a finite vector");
			}
			target.position = to_glm(value);
		} else if (!position.is_nil()) {
			throw Error("add_joint_target: position must be a Vector3 or null");
		}
		if (rotation.get_type() == Variant::QUATERNION || rotation.get_type() == Variant::BASIS) {
			const glm::quat world = rotation.get_type() == Variant::QUATERNION ? to_glm(Quaternion(rotation)) : glm::quat_cast(to_glm(Basis(rotation)));
			const float norm = glm::length(world);
			if (!std::isfinite(norm) || norm < 1e-6f) {
				throw Error("add_joint_target: rotation is not a finite non-zero rotation");
			}
			const size_t joint_index = *package_->skeleton().find(*joint);
			const int rig_bone = retargeter_->bone_of_joint()[joint_index];
			if (rig_bone < 0) {
				throw Error("add_joint_target: joint '" + *joint + "' has no bone in the rig to take a rotation from");
			}
			// A world rotation of the rig bone, as the model's world rotation of its joint.
			Skeleton3D *skeleton = find_skeleton();
			const glm::quat skeleton_rotation = skeleton != nullptr ? to_frame(skeleton->get_global_transform()).rotation() : glm::quat(1, 0, 0, 0);
			const glm::quat rig_global = glm::inverse(skeleton_rotation) * glm::normalize(world);
			target.rotation = retargeter_->model_global_rotation(static_cast<size_t>(rig_bone), rig_global, frame_rotation(find_skeleton()));
		} else if (!rotation.is_nil()) {
			throw Error("add_joint_target: rotation must be a Quaternion, a Basis or null");
		}
		if (!target.position && !target.rotation) {
			throw Error("add_joint_target: give a position, a rotation or both");
		}
		submit(target);
		joint_targets_.push_back(target);
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

std::vector<glm::quat> MotionGenerator::rig_pose_of(const Variant &pose, const char *what) const {
	Skeleton3D *skeleton = find_skeleton();
	const int32_t bones = skeleton->get_bone_count();
	std::vector<glm::quat> rig_local(static_cast<size_t>(bones));
	// Rest rotations first; the pose's bones over them.
	for (int32_t bone = 0; bone < bones; ++bone) {
		rig_local[static_cast<size_t>(bone)] = to_frame(skeleton->get_bone_rest(bone)).rotation();
	}
	if (auto *source = object_from_owner<Skeleton3D>(pose.object_ptr())) {
		if (source->get_bone_count() != bones) {
			throw Error(std::string(what) + ": the pose's Skeleton3D has " + std::to_string(source->get_bone_count()) + " bones, the driven one " +
					std::to_string(bones) + " (capture from a copy of the same rig)");
		}
		for (int32_t bone = 0; bone < bones; ++bone) {
			rig_local[static_cast<size_t>(bone)] = glm::normalize(to_glm(source->get_bone_pose_rotation(bone)));
		}
		return rig_local;
	}
	if (pose.get_type() != Variant::DICTIONARY) {
		throw Error(std::string(what) + ": pose must be a Skeleton3D or a Dictionary of bone name -> Quaternion or Transform3D");
	}
	const Dictionary entries = pose;
	const Array keys = entries.keys();
	for (int64_t i = 0; i < keys.size(); ++i) {
		const Variant key = keys[i];
		if (key.get_type() != Variant::STRING && key.get_type() != Variant::STRING_NAME) {
			throw Error(std::string(what) + ": pose keys must be bone names");
		}
		const String name = key;
		const int32_t bone = skeleton->find_bone(name);
		if (bone < 0) {
			throw Error(std::string(what) + ": unknown bone '" + text(name) + "'");
		}
		const Variant value = entries.get(key);
		glm::quat rotation;
		if (value.get_type() == Variant::QUATERNION) {
			rotation = to_glm(Quaternion(value));
		} else if (value.get_type() == Variant::TRANSFORM3D) {
			rotation = to_frame(Transform3D(value)).rotation();
		} else {
			throw Error(std::string(what) + ": bone '" + text(name) + "' needs a Quaternion or a Transform3D");
		}
		const float norm = glm::length(rotation);
		if (!std::isfinite(norm) || norm < 1e-6f) {
			throw Error(std::string(what) + ": bone '" + text(name) + "' has no finite non-zero rotation");
		}
		rig_local[static_cast<size_t>(bone)] = rotation / norm;
	}
	return rig_local;
}

Pose MotionGenerator::standing_pose(const Variant &pose, const char *what, std::optional<float> heading) const {
	if (!package_ || !retargeter_) {
		throw Error(std::string(what) + ": a pose needs the model and the rig to be ready (wait for model_loaded)");
	}
	Pose model_pose;
	model_pose.local_rotations = retargeter_->capture(rig_pose_of(pose, what), frame_rotation(find_skeleton()));
	glm::quat &hips = model_pose.local_rotations[0];
	const glm::vec3 forward = hips * glm::vec3(0.0f, 0.0f, 1.0f);
	const float pose_heading = std::atan2(forward.x, forward.z);
	if (heading) {
		hips = glm::normalize(glm::angleAxis(*heading - pose_heading, glm::vec3(0.0f, 1.0f, 0.0f)) * hips);
	}
	model_pose.heading = heading.value_or(pose_heading);
	// Stand it on the ground: its lowest joint just above height 0.
	std::vector<glm::mat3> local;
	for (const glm::quat &rotation : model_pose.local_rotations) {
		local.push_back(matrix_from_quat(rotation));
	}
	const GlobalPose global = forward_kinematics(package_->skeleton(), glm::vec3(0.0f), local);
	float lowest = 0.0f;
	for (const glm::vec3 &position : global.positions) {
		lowest = std::min(lowest, position.y);
	}
	model_pose.root_position = glm::vec3(0.0f, kGroundClearance - lowest, 0.0f);
	return model_pose;
}

void MotionGenerator::submit(PoseKeyframe &keyframe) {
	// The body takes the pose; where the character stands and faces then stays its own.
	Pose then;
	const std::optional<float> heading = planner_->sample(keyframe.time, then) ? std::optional<float>(then.heading) : std::nullopt;
	const Pose model_pose = standing_pose(keyframe.pose, "add_pose_keyframe", heading);
	keyframe.id = planner_->add_keyframe_pose(keyframe.time, model_pose, false);
}

void MotionGenerator::add_pose_keyframe(const Variant &pose, double at_seconds) {
	try {
		check_time(at_seconds, "add_pose_keyframe");
		if (find_skeleton() == nullptr) {
			throw Error("add_pose_keyframe: skeleton does not point to a Skeleton3D");
		}
		// Kept as bone name -> rotation, as a MotionKeyframe saves it.
		const std::vector<glm::quat> rig_local = rig_pose_of(pose, "add_pose_keyframe");
		Skeleton3D *skeleton = find_skeleton();
		Dictionary bones;
		if (pose.get_type() == Variant::DICTIONARY) {
			bones = pose;
		} else {
			for (size_t bone = 0; bone < rig_local.size(); ++bone) {
				bones.set(skeleton->get_bone_name(static_cast<int32_t>(bone)), to_godot(rig_local[bone]));
			}
		}
		PoseKeyframe keyframe;
		keyframe.time = at_seconds;
		keyframe.pose = bones;
		if (planner_ && retargeter_) {
			submit(keyframe);
		}
		keyframes_.push_back(keyframe);
		MotionKeyframe *resource = memnew_object<MotionKeyframe>();
		resource->set_time(at_seconds);
		resource->set_pose(bones);
		keyframe_resources_.push_back(Variant(resource));
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

void MotionGenerator::set_keyframes(const Array &keyframes) {
	try {
		std::vector<PoseKeyframe> list;
		for (int64_t i = 0; i < keyframes.size(); ++i) {
			auto *resource = object_from_owner<MotionKeyframe>(keyframes[i].object_ptr());
			if (resource == nullptr) {
				throw Error("keyframes: entry " + std::to_string(i) + " is not a MotionKeyframe");
			}
			if (!std::isfinite(resource->get_time())) {
				throw Error("keyframes: entry " + std::to_string(i) + " has a time that is not finite");
			}
			PoseKeyframe keyframe;
			keyframe.time = resource->get_time();
			keyframe.pose = resource->get_pose();
			if (find_skeleton() != nullptr) {
				rig_pose_of(keyframe.pose, "keyframes");  // names the bad bone now, not at play
			}
			list.push_back(keyframe);
		}
		replace_goals(keyframes_, std::move(list));
		keyframe_resources_ = keyframes;
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

Array MotionGenerator::get_keyframes() const {
	return keyframe_resources_;
}

void MotionGenerator::clear_constraints() {
	if (planner_) {
		planner_->clear_constraints();
	}
	clear_goal_lists();
}

void MotionGenerator::clear_goal_lists() {
	waypoints_.clear();
	waypoint_resources_ = Array();
	path_.reset();
	joint_targets_.clear();
	keyframes_.clear();
	keyframe_resources_ = Array();
}

void MotionGenerator::submit_world_goals() {
	const double now = get_time();
	for (WorldWaypoint &waypoint : waypoints_) {
		if (waypoint.time >= now && !waypoint.reached) {
			planner_->remove_constraint(waypoint.id);
			submit(waypoint);
		}
	}
	if (path_) {
		planner_->remove_constraint(path_->id);
		submit(*path_);
	}
	for (WorldJointTarget &target : joint_targets_) {
		if (target.time >= now && target.position) {
			planner_->remove_constraint(target.id);
			submit(target);
		}
	}
}

void MotionGenerator::reset(const Variant &pose) {
	try {
		std::vector<float> initial_history;
		if (!pose.is_nil()) {
			// The pose, held still for one token, is the history the motion continues.
			const Pose model_pose = standing_pose(pose, "reset", std::nullopt);
			const Skeleton &skeleton = package_->skeleton();
			const FeatureLayout &layout = package_->layout();
			std::vector<glm::mat3> local;
			for (const glm::quat &rotation : model_pose.local_rotations) {
				local.push_back(matrix_from_quat(rotation));
			}
			const GlobalPose global = forward_kinematics(skeleton, model_pose.root_position, local);
			MotionFrame frame;
			frame.root_position = model_pose.root_position;
			frame.heading_cos = std::cos(model_pose.heading);
			frame.heading_sin = std::sin(model_pose.heading);
			frame.rotations = global.rotations;
			frame.positions = global.positions;
			frame.velocities.assign(skeleton.joint_count(), glm::vec3(0.0f));
			frame.contacts.assign(layout.contact_count(), 1.0f);
			const size_t frames = package_->tokens().patch;
			initial_history.resize(frames * layout.feature_size);
			for (size_t f = 0; f < frames; ++f) {
				pack_frame(layout, frame, initial_history.data() + f * layout.feature_size);
			}
		}
		stop_planner();
		clear_goal_lists();
		queued_prompts_.clear();
		if (package_ && is_active()) {
			start_planner(initial_history);
		}
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
}

// --- timeline --------------------------------------------------------------------

namespace {

// Where the root is planned to be at any frame, from the timeline's root
// goals (waypoints and paths) and where it starts: positions linear between
// goals, headings from a goal's own or the direction of travel. Joint targets
// (relative to the root then) and keyframes (facing the way the character
// faces then) are placed with it, before any motion exists.
class RootPlan {
public:
	RootPlan(int64_t start_frame, const glm::dvec2 &start, double start_heading, const std::vector<Constraint> &constraints) :
			start_heading_(start_heading) {
		samples_.push_back({ start_frame, start, start_heading });
		for (const Constraint &constraint : constraints) {
			if (const auto *waypoint = std::get_if<RootWaypoint>(&constraint)) {
				samples_.push_back({ waypoint->frame, { waypoint->x, waypoint->z }, waypoint->heading });
			} else if (const auto *path = std::get_if<RootPath>(&constraint)) {
				for (size_t i = 0; i < path->positions.size(); ++i) {
					std::optional<double> heading;
					if (!path->headings.empty()) {
						heading = path->headings[i];
					}
					samples_.push_back({ path->start_frame + static_cast<int64_t>(i), path->positions[i], heading });
				}
			}
		}
		std::stable_sort(samples_.begin(), samples_.end(), [](const Sample &a, const Sample &b) { return a.frame < b.frame; });
	}

	glm::dvec2 position(int64_t frame) const {
		const auto [before, after] = bracket(frame);
		if (before == after || after->frame == before->frame) {
			return before->position;
		}
		const double blend = double(frame - before->frame) / double(after->frame - before->frame);
		return before->position + blend * (after->position - before->position);
	}

	double heading(int64_t frame) const {
		const auto [before, after] = bracket(frame);
		if (before->frame == frame && before->heading) {
			return *before->heading;
		}
		if (after->frame == frame && after->heading) {
			return *after->heading;
		}
		const glm::dvec2 travel = after->position - before->position;
		if (glm::length(travel) > 0.05) {
			return std::atan2(travel.x, travel.y);
		}
		return before->heading.value_or(start_heading_);
	}

private:
	struct Sample {
		int64_t frame = 0;
		glm::dvec2 position{ 0.0 };
		std::optional<double> heading;
	};
	using Iterator = std::vector<Sample>::const_iterator;

	// The last sample at or before `frame` and the first after it (both the
	// last one past the end; both the first one before the start).
	std::pair<Iterator, Iterator> bracket(int64_t frame) const {
		const auto after = std::upper_bound(samples_.begin(), samples_.end(), frame, [](int64_t f, const Sample &s) { return f < s.frame; });
		if (after == samples_.begin()) {
			return { after, after };
		}
		if (after == samples_.end()) {
			return { std::prev(after), std::prev(after) };
		}
		return { std::prev(after), after };
	}

	double start_heading_ = 0.0;
	std::vector<Sample> samples_;
};

template <class Item>
Item *timeline_item(const Array &items, int64_t index, const char *track) {
	auto *item = object_from_owner<Item>(items[index].object_ptr());
	if (item == nullptr) {
		throw Error(std::string("timeline ") + track + "[" + std::to_string(index) + "] is not a " + Item::get_class_static());
	}
	return item;
}

void check_item_time(double seconds, const std::string &where) {
	if (!std::isfinite(seconds) || seconds < 0.0 || seconds > 3600.0) {
		throw Error(where + ": time " + std::to_string(seconds) + " s is outside 0..3600");
	}
}

} // namespace

void MotionGenerator::set_timeline(const Ref<MotionTimeline> &timeline) {
	if (planner_) {
		for (const Planner::ConstraintId id : timeline_ids_) {
			planner_->remove_constraint(id);
		}
	}
	timeline_ids_.clear();
	timeline_ = timeline;
	timeline_cycles_ = 0;
	timeline_finished_ = false;
	clip_.reset();
	showing_clip_ = false;
	if (in_editor_ && in_tree_) {
		update_gizmos();  // the timeline's goals are drawn in the viewport
	}
	if (planner_) {
		// From now on: the prompts queued by the timeline before are forgotten.
		const double now = get_time();
		planner_->reset_prompts_at(now, prompt_.is_empty() ? std::nullopt : std::optional<std::string>(text(prompt_)));
		timeline_start_ = now;
		if (timeline_.is_valid()) {
			start_timeline_cycle(now);
		}
	} else {
		timeline_start_ = 0.0;
	}
}

Ref<MotionTimeline> MotionGenerator::get_timeline() const {
	return timeline_;
}

Timeline MotionGenerator::build_timeline(const Anchor &anchor, double offset, const RootStart &start) const {
	Timeline out;
	if (!package_ || !retargeter_) {
		throw Error("the timeline needs the model and the skeleton to be ready (wait for model_loaded)");
	}
	const double fps = package_->fps();
	const auto frame_of = [&](double seconds) { return seconds_to_frame(offset + seconds, fps); };
	if (!prompt_.is_empty()) {
		out.prompts.push_back({ frame_of(0.0), text(prompt_) });
	}
	if (timeline_.is_null()) {
		return out;
	}
	const MotionTimeline &timeline = *timeline_.ptr();
	const Array prompts = timeline.get_prompts();
	for (int64_t i = 0; i < prompts.size(); ++i) {
		const std::string where = "timeline prompts[" + std::to_string(i) + "]";
		const MotionPrompt *prompt = timeline_item<MotionPrompt>(prompts, i, "prompts");
		check_item_time(prompt->get_time(), where);
		PromptEvent event{ frame_of(prompt->get_time()), std::nullopt };
		if (!prompt->get_text().is_empty()) {
			event.text = text(prompt->get_text());
			try {
				package_->text_encoder().normalize_prompt(*event.text);
			} catch (const std::exception &failure) {
				throw Error(where + ": " + failure.what());
			}
		}
		out.prompts.push_back(std::move(event));
	}
	// Root goals first: the plan of where the root is comes from them.
	const Array waypoints = timeline.get_waypoints();
	for (int64_t i = 0; i < waypoints.size(); ++i) {
		const std::string where = "timeline waypoints[" + std::to_string(i) + "]";
		const MotionWaypoint *waypoint = timeline_item<MotionWaypoint>(waypoints, i, "waypoints");
		check_item_time(waypoint->get_time(), where);
		if (!finite(waypoint->get_position()) || !std::isfinite(waypoint->get_heading())) {
			throw Error(where + ": the position or heading is not finite");
		}
		const glm::vec3 model = anchor.to_model(to_glm(waypoint->get_position()));
		RootWaypoint goal{ frame_of(waypoint->get_time()), model.x, model.z, std::nullopt };
		if (waypoint->get_use_heading()) {
			goal.heading = waypoint->get_heading() - anchor.yaw_angle;
		}
		out.constraints.push_back(goal);
	}
	const Array paths = timeline.get_paths();
	for (int64_t i = 0; i < paths.size(); ++i) {
		const std::string where = "timeline paths[" + std::to_string(i) + "]";
		const MotionPath *path = timeline_item<MotionPath>(paths, i, "paths");
		check_item_time(path->get_start_time(), where);
		const PackedVector3Array points = path->get_points();
		if (points.size() < 2) {
			throw Error(where + ": the path has " + std::to_string(points.size()) + " points, at least 2 are needed");
		}
		if (!std::isfinite(path->get_speed()) || path->get_speed() <= 0.0 || path->get_speed() > 10.0) {
			throw Error(where + ": speed " + std::to_string(path->get_speed()) + " is out of range (more than 0, at most 10 m/s)");
		}
		std::vector<glm::dvec2> model_points;
		for (int64_t p = 0; p < points.size(); ++p) {
			if (!finite(points[p])) {
				throw Error(where + ": point " + std::to_string(p) + " is not a finite vector");
			}
			const glm::vec3 model = anchor.to_model(to_glm(points[p]));
			model_points.emplace_back(model.x, model.z);
		}
		try {
			out.constraints.push_back(path_from_polyline(model_points, path->get_speed() / anchor.scale, frame_of(path->get_start_time()), fps));
		} catch (const std::exception &failure) {
			throw Error(where + ": " + failure.what());
		}
	}
	const RootPlan plan(start.frame, start.position, start.heading, out.constraints);
	const Array keyframes = timeline.get_keyframes();
	for (int64_t i = 0; i < keyframes.size(); ++i) {
		const std::string where = "timeline keyframes[" + std::to_string(i) + "]";
		const MotionKeyframe *keyframe = timeline_item<MotionKeyframe>(keyframes, i, "keyframes");
		check_item_time(keyframe->get_time(), where);
		const int64_t frame = frame_of(keyframe->get_time());
		// The body takes the pose; where the character stands then stays its own.
		const Pose model_pose = standing_pose(keyframe->get_pose(), where.c_str(), static_cast<float>(plan.heading(frame)));
		out.constraints.push_back(keyframe_from_pose(*package_, frame, model_pose, false, where.c_str()));
	}
	const Array targets = timeline.get_joint_targets();
	Skeleton3D *skeleton = find_skeleton();
	for (int64_t i = 0; i < targets.size(); ++i) {
		const std::string where = "timeline joint_targets[" + std::to_string(i) + "]";
		const MotionJointTarget *target = timeline_item<MotionJointTarget>(targets, i, "joint_targets");
		check_item_time(target->get_time(), where);
		const std::optional<std::string> joint = model_joint_of(target->get_bone());
		if (!joint) {
			throw Error(where + ": unknown bone '" + text(target->get_bone()) + "' (a bone of the skeleton mapped to the model, or a model joint)");
		}
		const int64_t frame = frame_of(target->get_time());
		JointTargetSpec spec;
		spec.joint = *joint;
		if (target->get_use_position()) {
			if (!finite(target->get_position())) {
				throw Error(where + ": position is not a finite vector");
			}
			spec.position = glm::dvec3(anchor.to_model(to_glm(target->get_position())));
			spec.root_xz = plan.position(frame);
		}
		if (target->get_use_rotation()) {
			const glm::quat world = to_glm(target->get_rotation());
			const float norm = glm::length(world);
			if (!std::isfinite(norm) || norm < 1e-6f) {
				throw Error(where + ": rotation is not a finite non-zero rotation");
			}
			const int rig_bone = retargeter_->bone_of_joint()[*package_->skeleton().find(*joint)];
			if (rig_bone < 0) {
				throw Error(where + ": joint '" + *joint + "' has no bone in the rig to take a rotation from");
			}
			const glm::quat skeleton_rotation = skeleton != nullptr ? to_frame(skeleton->get_global_transform()).rotation() : glm::quat(1, 0, 0, 0);
			const glm::quat rig_global = glm::inverse(skeleton_rotation) * glm::normalize(world);
			spec.rotation = glm::dquat(retargeter_->model_global_rotation(static_cast<size_t>(rig_bone), rig_global, frame_rotation(skeleton_rotation, anchor)));
		}
		if (!spec.position && !spec.rotation) {
			throw Error(where + ": use_position and use_rotation are both off");
		}
		out.constraints.push_back(joint_target_from_spec(*package_, frame, spec, where.c_str()));
	}
	const Array contacts = timeline.get_contacts();
	const std::vector<std::string> &contact_joints = package_->contact_joints();
	for (int64_t i = 0; i < contacts.size(); ++i) {
		const std::string where = "timeline contacts[" + std::to_string(i) + "]";
		const MotionContact *contact = timeline_item<MotionContact>(contacts, i, "contacts");
		check_item_time(contact->get_start_time(), where);
		check_item_time(contact->get_end_time(), where);
		FootContact goal;
		goal.start_frame = frame_of(contact->get_start_time());
		goal.end_frame = frame_of(contact->get_end_time());
		if (goal.end_frame <= goal.start_frame) {
			throw Error(where + ": end_time must be after start_time");
		}
		goal.value = contact->get_planted() ? 1.0 : 0.0;
		if (contact->get_feet() != MotionContact::FEET_BOTH) {
			const std::string side = contact->get_feet() == MotionContact::FEET_LEFT ? "_L" : "_R";
			for (size_t foot = 0; foot < contact_joints.size(); ++foot) {
				const std::string &name = contact_joints[foot];
				if (name.size() >= 2 && name.compare(name.size() - 2, 2, side) == 0) {
					goal.feet.push_back(foot);
				}
			}
			if (goal.feet.empty()) {
				throw Error(where + ": the model has no " + (side == "_L" ? "left" : "right") + " contact joint");
			}
		}
		validate_constraint(goal, package_->layout(), where);
		out.constraints.push_back(goal);
	}
	return out;
}

void MotionGenerator::start_timeline_cycle(double offset) {
	RootStart start;
	Pose now;
	if (planner_->sample(offset, now)) {
		start.frame = seconds_to_frame(offset, package_->fps());
		start.position = glm::dvec2(now.root_position.x, now.root_position.z);
		start.heading = now.heading;
	}
	try {
		Timeline cycle = build_timeline(anchor_, offset, start);
		for (PromptEvent &event : cycle.prompts) {
			const double seconds = static_cast<double>(event.frame) / package_->fps();
			if (event.text) {
				planner_->set_prompt_at(seconds, *event.text);
			} else {
				planner_->clear_prompt_at(seconds);
			}
		}
		for (Constraint &constraint : cycle.constraints) {
			timeline_ids_.push_back(planner_->add_constraint(std::move(constraint)));
		}
	} catch (const std::exception &failure) {
		fail(failure.what());
	}
	++timeline_cycles_;
}

void MotionGenerator::advance_timeline() {
	if (timeline_.is_null() || !planner_) {
		return;
	}
	const double length = timeline_->get_length();
	if (!(length > 0.0)) {
		return;
	}
	const double now = get_time();
	if (timeline_->get_loop()) {
		// The next cycle goes in when this one starts, so the planner sees it coming.
		while (now >= timeline_start_ + static_cast<double>(timeline_cycles_ - 1) * length) {
			start_timeline_cycle(timeline_start_ + static_cast<double>(timeline_cycles_) * length);
		}
	} else if (!timeline_finished_ && now >= timeline_start_ + length) {
		timeline_finished_ = true;
		emit_signal("timeline_finished");
	}
}

// --- the clip ----------------------------------------------------------------------

bool MotionGenerator::load_model_now(const char *what) {
	if (!in_tree_) {
		return fail(std::string(what) + ": the node is not in the scene tree");
	}
	const std::string path = text(model_path_);
	if (!package_ || (model_ && model_->path() != path)) {
		if (!pending_model_ || pending_model_->path() != path) {
			if (path.empty()) {
				return fail(std::string(what) + ": model_path is empty");
			}
			pending_model_ = acquire_model(path);
		}
		// Loading takes a second or two; this call was asked to finish the work.
		const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
		while (!pending_model_->is_done() && std::chrono::steady_clock::now() < deadline) {
			std::this_thread::sleep_for(std::chrono::milliseconds(5));
		}
		poll_model();
		if (!package_) {
			return fail(std::string(what) + ": the model '" + path + "' is not loaded" + (last_error_.empty() ? "" : " (" + last_error_ + ")"));
		}
	}
	Skeleton3D *skeleton = find_skeleton();
	if (skeleton == nullptr) {
		return fail(std::string(what) + ": skeleton does not point to a Skeleton3D");
	}
	if (!build_rig(skeleton)) {
		return fail(std::string(what) + ": the skeleton cannot be driven (" + last_error_ + ")");
	}
	return true;
}

bool MotionGenerator::generate_clip(double seconds) {
	if (!std::isfinite(seconds) || seconds > 3600.0) {
		return fail("generate_clip: seconds is " + std::to_string(seconds) + ", expected at most 3600 (or < 0 for the timeline's length)");
	}
	if (!load_model_now("generate_clip")) {
		return false;
	}
	if (seconds <= 0.0) {
		seconds = timeline_.is_valid() ? timeline_->get_length() : 10.0;
	}
	try {
		Clip clip;
		clip.anchor = make_anchor();
		Timeline timeline = build_timeline(clip.anchor, 0.0, RootStart{});
		PlannerConfig config = planner_config({});
		config.generator = {};  // its own worker: the shared one serves live characters
		config.prompt.reset();  // in the timeline's prompts
		config.initial_prompts = std::move(timeline.prompts);
		config.initial_constraints = std::move(timeline.constraints);
		clip.motion = generate_offline(package_, std::move(config), seconds);
		clip_ = std::move(clip);
		if (in_editor_) {
			update_gizmos();  // keyframe ghosts stand where the clip puts the character
		}
	} catch (const std::exception &failure) {
		return fail(std::string("generate_clip: ") + failure.what());
	}
	return true;
}

bool MotionGenerator::has_clip() const {
	return clip_.has_value();
}

double MotionGenerator::get_clip_length() const {
	return clip_ ? clip_->motion.seconds() : 0.0;
}

void MotionGenerator::clear_clip() {
	clip_.reset();
	showing_clip_ = false;
	has_rig_pose_ = false;
}

void MotionGenerator::rig_pose_at(const Clip &clip, double seconds, Skeleton3D *skeleton, Pose &pose, RigPose &rig_pose) const {
	sample_offline(clip.motion, seconds, pose);
	// As the live pose without a root motion target: the whole motion in the skeleton.
	const Frame skeleton_frame = to_frame(skeleton->get_global_transform());
	const glm::vec3 hips = skeleton_frame.apply_inverse(clip.anchor.to_world(pose.root_position));
	retargeter_->apply(pose.local_rotations, frame_rotation(skeleton_frame.rotation(), clip.anchor), hips, rig_pose);
}

void MotionGenerator::seek_clip(double seconds) {
	if (!clip_) {
		fail("seek_clip: there is no clip (call generate_clip first)");
		return;
	}
	if (!std::isfinite(seconds)) {
		fail("seek_clip: seconds is not a finite number");
		return;
	}
	if (in_editor_ && !preview_in_editor_) {
		fail("seek_clip: turn on preview_in_editor to show the clip in the editor");
		return;
	}
	Skeleton3D *skeleton = find_skeleton();
	if (!build_rig(skeleton)) {
		fail("seek_clip: skeleton does not point to a Skeleton3D that can be driven");
		return;
	}
	if (!showing_clip_) {
		stop_planner();
		showing_clip_ = true;
	}
	rig_pose_at(*clip_, seconds, skeleton, pose_, rig_pose_);
	has_pose_ = true;
	has_rig_pose_ = true;
	posed_skeleton_ = skeleton;
	hips_world_ = clip_->anchor.to_world(pose_.root_position);
	ensure_modifier(skeleton);
}

Variant MotionGenerator::get_clip_root(double seconds) const {
	Pose pose;
	if (!clip_ || !sample_offline(clip_->motion, seconds, pose)) {
		return Variant();
	}
	Frame character;
	character.basis = heading_rotation(clip_->anchor.yaw_angle + pose.heading);
	character.origin = clip_->anchor.to_world(glm::vec3(pose.root_position.x, 0.0f, pose.root_position.z));
	return to_godot(character);
}

Variant MotionGenerator::bake_animation(double seconds, double fps, Node *root_node) {
	if (!std::isfinite(fps) || fps < 1.0 || fps > 240.0) {
		fail("bake_animation: fps is " + std::to_string(fps) + ", expected 1..240");
		return Variant();
	}
	if (std::isfinite(seconds) && seconds <= 0.0) {
		seconds = timeline_.is_valid() ? timeline_->get_length() : 10.0;
	}
	if (!load_model_now("bake_animation")) {
		return Variant();
	}
	// One model frame more, so the animation's last key is at `seconds` itself.
	const double frame_seconds = 1.0 / package_->fps();
	if (!generate_clip(std::isfinite(seconds) ? std::min(seconds + frame_seconds, 3600.0) : seconds)) {
		return Variant();
	}
	Node *root = root_node != nullptr ? root_node : get_parent();
	Skeleton3D *skeleton = find_skeleton();
	if (root == nullptr) {
		fail("bake_animation: no root_node given and the generator has no parent to make track paths from");
		return Variant();
	}
	const std::string skeleton_path = text(String(root->get_path_to(skeleton)));
	if (skeleton_path.empty() || skeleton_path.front() == '/') {
		fail("bake_animation: the skeleton is not in the same scene tree as root_node");
		return Variant();
	}
	Animation *animation = memnew_object<Animation>();
	const Variant result(animation);  // holds the reference
	const double length = std::min(seconds, clip_->motion.seconds() - 1.0 / clip_->motion.fps);
	const auto keys = static_cast<int64_t>(std::floor(length * fps + 1e-6)) + 1;
	Pose pose;
	RigPose rig_pose;
	rig_pose_at(*clip_, 0.0, skeleton, pose, rig_pose);
	const int root_bone = retargeter_->root_bone();
	const auto track_path = [&](int bone) { return NodePath(String(skeleton_path + ":" + text(skeleton->get_bone_name(bone)))); };
	std::vector<std::pair<int, int32_t>> rotation_tracks;  // bone, track
	for (size_t bone = 0; bone < rig_pose.written.size(); ++bone) {
		if (rig_pose.written[bone]) {
			const int32_t track = animation->add_track(Animation::TYPE_ROTATION_3D);
			animation->track_set_path(track, track_path(static_cast<int>(bone)));
			rotation_tracks.emplace_back(static_cast<int>(bone), track);
		}
	}
	const int32_t position_track = animation->add_track(Animation::TYPE_POSITION_3D);
	animation->track_set_path(position_track, track_path(root_bone));
	for (int64_t key = 0; key < keys; ++key) {
		const double time = std::min(static_cast<double>(key) / fps, length);
		rig_pose_at(*clip_, time, skeleton, pose, rig_pose);
		for (const auto &[bone, track] : rotation_tracks) {
			animation->rotation_track_insert_key(track, time, to_godot(rig_pose.local_rotations[static_cast<size_t>(bone)]));
		}
		animation->position_track_insert_key(position_track, time, to_godot(rig_pose.root_position));
	}
	animation->set_length(length);
	animation->set_step(1.0 / fps);
	animation->set_loop_mode(timeline_.is_valid() && timeline_->get_loop() ? Animation::LOOP_LINEAR : Animation::LOOP_NONE);
	return result;
}

int64_t MotionGenerator::export_bvh(const String &path, double seconds) {
	if (!generate_clip(seconds)) {
		return godot::ERR_UNCONFIGURED;
	}
	Ref<FileAccess> file = FileAccess::open(path, FileAccess::WRITE);
	if (file.is_null()) {
		const godot::Error error = FileAccess::get_open_error();
		fail("export_bvh: cannot open '" + text(path) + "' for writing: " + text(error_string(error)));
		return error;
	}
	file->store_string(String(motion_to_bvh(package_->skeleton(), clip_->motion.fps, clip_->motion.frames)));
	if (file->get_error() != godot::OK) {
		fail("export_bvh: cannot write '" + text(path) + "': " + text(error_string(file->get_error())));
		return file->get_error();
	}
	return godot::OK;
}

String MotionGenerator::timeline_to_json() {
	if (!load_model_now("timeline_to_json")) {
		return String();
	}
	try {
		const Timeline timeline = build_timeline(make_anchor(), 0.0, RootStart{});
		return String(ardy::timeline_to_json(timeline, *package_).dump(1));
	} catch (const std::exception &failure) {
		fail(std::string("timeline_to_json: ") + failure.what());
		return String();
	}
}

Variant MotionGenerator::timeline_from_json(const String &json) {
	if (!load_model_now("timeline_from_json")) {
		return Variant();
	}
	try {
		const Timeline parsed = parse_timeline_text(text(json), *package_, "timeline_from_json");
		const Anchor anchor = make_anchor();
		const double fps = package_->fps();
		const auto seconds_of = [&](int64_t frame) { return static_cast<double>(frame) / fps; };
		const auto world_of = [&](double x, double z) { return to_godot(anchor.to_world(glm::vec3(float(x), 0.0f, float(z)))); };
		MotionTimeline *timeline = memnew_object<MotionTimeline>();
		const Variant result(timeline);  // holds the reference
		Array prompts, waypoints, paths, keyframes, targets, contacts;
		int64_t last_frame = 0;
		for (const PromptEvent &event : parsed.prompts) {
			MotionPrompt *prompt = memnew_object<MotionPrompt>();
			prompts.push_back(Variant(prompt));
			prompt->set_time(seconds_of(event.frame));
			prompt->set_text(String(event.text.value_or("")));
			last_frame = std::max(last_frame, event.frame);
		}
		const RootPlan plan(0, glm::dvec2(0.0), 0.0, parsed.constraints);
		Skeleton3D *skeleton = find_skeleton();
		const glm::quat frame = frame_rotation(to_frame(skeleton->get_global_transform()).rotation(), anchor);
		for (size_t index = 0; index < parsed.constraints.size(); ++index) {
			const Constraint &constraint = parsed.constraints[index];
			const std::string where = "timeline_from_json: constraints[" + std::to_string(index) + "]";
			last_frame = std::max(last_frame, constraint_frames(constraint).second);
			if (const auto *goal = std::get_if<RootWaypoint>(&constraint)) {
				MotionWaypoint *waypoint = memnew_object<MotionWaypoint>();
				waypoints.push_back(Variant(waypoint));
				waypoint->set_time(seconds_of(goal->frame));
				waypoint->set_position(world_of(goal->x, goal->z));
				waypoint->set_use_heading(goal->heading.has_value());
				waypoint->set_heading(goal->heading ? *goal->heading + anchor.yaw_angle : 0.0);
			} else if (const auto *goal = std::get_if<RootPath>(&constraint)) {
				// A polyline through every frame's position, walked at the path's mean speed.
				PackedVector3Array points;
				double length = 0.0;
				for (size_t p = 0; p < goal->positions.size(); ++p) {
					points.push_back(world_of(goal->positions[p].x, goal->positions[p].y));
					if (p > 0) {
						length += glm::length(goal->positions[p] - goal->positions[p - 1]);
					}
				}
				const double duration = seconds_of(static_cast<int64_t>(goal->positions.size()) - 1);
				if (goal->positions.size() < 2 || !(length > 1e-6)) {
					throw Error(where + ": a path that does not move has no MotionPath form (use a waypoint)");
				}
				MotionPath *path = memnew_object<MotionPath>();
				paths.push_back(Variant(path));
				path->set_start_time(seconds_of(goal->start_frame));
				path->set_points(points);
				path->set_speed(length * anchor.scale / duration);
			} else if (const auto *goal = std::get_if<ardy::PoseKeyframe>(&constraint)) {
				std::vector<float> features(goal->features.begin(), goal->features.end());
				const MotionFrame pose = unpack_frame(package_->layout(), features.data());
				std::vector<glm::quat> model_local(pose.rotations.size());
				const Skeleton &model = package_->skeleton();
				for (size_t joint = 0; joint < model_local.size(); ++joint) {
					const int parent = model.parent(joint);
					const glm::mat3 local = parent < 0 ? pose.rotations[joint] : glm::transpose(pose.rotations[static_cast<size_t>(parent)]) * pose.rotations[joint];
					model_local[joint] = quat_from_matrix(local);
				}
				RigPose rig_pose;
				retargeter_->apply(model_local, frame, glm::vec3(0.0f), rig_pose);
				Dictionary bones;
				for (size_t bone = 0; bone < rig_pose.written.size(); ++bone) {
					if (rig_pose.written[bone]) {
						bones.set(skeleton->get_bone_name(static_cast<int32_t>(bone)), to_godot(rig_pose.local_rotations[bone]));
					}
				}
				MotionKeyframe *keyframe = memnew_object<MotionKeyframe>();
				keyframes.push_back(Variant(keyframe));
				keyframe->set_time(seconds_of(goal->frame));
				keyframe->set_pose(bones);
			} else if (const auto *goal = std::get_if<JointTarget>(&constraint)) {
				if (goal->rotation) {
					throw Error(where + ": joint rotation targets cannot be imported (only positions)");
				}
				glm::dvec3 position = *goal->position;
				if (goal->joint != 0) {
					const glm::dvec2 root = plan.position(goal->frame);
					position += glm::dvec3(root.x, 0.0, root.y);
				}
				MotionJointTarget *target = memnew_object<MotionJointTarget>();
				targets.push_back(Variant(target));
				target->set_time(seconds_of(goal->frame));
				target->set_bone(String(package_->skeleton().name(goal->joint)));
				target->set_use_position(true);
				target->set_position(to_godot(anchor.to_world(glm::vec3(position))));
			} else if (const auto *goal = std::get_if<FootContact>(&constraint)) {
				bool left = goal->feet.empty(), right = goal->feet.empty();
				for (size_t foot : goal->feet) {
					const std::string &name = package_->contact_joints()[foot];
					(name.size() >= 2 && name.compare(name.size() - 2, 2, "_L") == 0 ? left : right) = true;
				}
				MotionContact *contact = memnew_object<MotionContact>();
				contacts.push_back(Variant(contact));
				contact->set_start_time(seconds_of(goal->start_frame));
				contact->set_end_time(seconds_of(goal->end_frame));
				contact->set_feet(left && right ? MotionContact::FEET_BOTH : (left ? MotionContact::FEET_LEFT : MotionContact::FEET_RIGHT));
				contact->set_planted(goal->value >= 0.5);
			}
		}
		timeline->set_prompts(prompts);
		timeline->set_waypoints(waypoints);
		timeline->set_paths(paths);
		timeline->set_keyframes(keyframes);
		timeline->set_joint_targets(targets);
		timeline->set_contacts(contacts);
		timeline->set_length(std::max(1.0, seconds_of(last_frame + 1)));
		return result;
	} catch (const std::exception &failure) {
		fail(std::string(failure.what()).rfind("timeline_from_json", 0) == 0 ? failure.what() : std::string("timeline_from_json: ") + failure.what());
		return Variant();
	}
}

// --- reports -------------------------------------------------------------------

double MotionGenerator::get_time() const {
	return planner_ ? planner_->time() : 0.0;
}

Variant MotionGenerator::get_planned_root(double at_seconds) const {
	Pose planned;
	if (!planner_ || !std::isfinite(at_seconds) || !planner_->sample(at_seconds, planned)) {
		return Variant();
	}
	Frame character;
	character.basis = heading_rotation(anchor_.yaw_angle + planned.heading);
	character.origin = anchor_.to_world(glm::vec3(planned.root_position.x, 0.0f, planned.root_position.z));
	return to_godot(character);
}

Dictionary MotionGenerator::get_stats() const {
	Dictionary stats;
	stats.set("last_latency_ms", last_latency_ms_);
	stats.set("median_latency_ms", median(std::vector<double>(latencies_ms_.begin(), latencies_ms_.end())));
	const size_t costs = std::min(frame_cost_index_, frame_microseconds_.size());
	stats.set("main_thread_usec", median(std::vector<double>(frame_microseconds_.begin(), frame_microseconds_.begin() + static_cast<std::ptrdiff_t>(costs))));
	if (planner_) {
		const PlannerStats planner = planner_->stats();
		stats.set("windows", static_cast<int64_t>(planner.windows_published));
		stats.set("splices", static_cast<int64_t>(planner.splices));
		stats.set("late_windows", static_cast<int64_t>(planner.late_windows));
		stats.set("failed_windows", static_cast<int64_t>(planner.failed_windows));
		stats.set("underrun_seconds", planner.underrun_seconds);
		stats.set("buffered_seconds", planner.queued_seconds);
		stats.set("buffer_frames", planner.buffer_frames);
		stats.set("history_seconds", std::min(history_seconds_, planner_->time()));
	} else {
		stats.set("windows", static_cast<int64_t>(0));
		stats.set("splices", static_cast<int64_t>(0));
		stats.set("late_windows", static_cast<int64_t>(0));
		stats.set("failed_windows", static_cast<int64_t>(0));
		stats.set("underrun_seconds", 0.0);
		stats.set("buffered_seconds", 0.0);
		stats.set("buffer_frames", static_cast<int64_t>(0));
		stats.set("history_seconds", 0.0);
	}
	if (model_) {
		const WindowBatcherStats batcher = model_->batcher_stats();
		stats.set("batches", static_cast<int64_t>(batcher.batches));
		stats.set("largest_batch", static_cast<int64_t>(batcher.largest_batch));
	}
	// Process-wide, so a HUD can show the cores all characters use together.
	stats.set("generation_cpu_seconds", generation_cpu_seconds());
	return stats;
}

PackedStringArray MotionGenerator::get_joint_names() const {
	PackedStringArray names;
	if (package_) {
		for (const std::string &name : package_->skeleton().names()) {
			names.push_back(String(name));
		}
	}
	return names;
}

// What the sampling properties' "model's default" values (0 steps, a negative weight or
// scale) stand for, so that a settings UI can show them.
Dictionary MotionGenerator::get_model_sampling() const {
	Dictionary sampling;
	if (package_) {
		const SamplingDefaults &defaults = package_->sampling_defaults();
		sampling.set("steps", static_cast<int64_t>(defaults.steps));
		sampling.set("text_guidance", defaults.w_text);
		sampling.set("constraint_guidance", defaults.w_con);
		sampling.set("path_guidance_scale", defaults.path_guidance_scale);
		sampling.set("text_only_guidance_scale", defaults.text_only_guidance_scale);
	}
	return sampling;
}

bool MotionGenerator::is_model_loaded() const {
	return package_ != nullptr;
}

bool MotionGenerator::is_generating() const {
	return planner_ != nullptr;
}

String MotionGenerator::get_last_error() const {
	return String(last_error_);
}

bool MotionGenerator::fail(const std::string &message) {
	last_error_ = message;
	ERR_PRINT("MotionGenerator: " + message);
	emit_signal("generation_failed", String(message));
	return false;
}

// --- life cycle ------------------------------------------------------------------

bool MotionGenerator::is_active() const {
	return in_editor_ ? preview_in_editor_ : true;
}

void MotionGenerator::request_model() {
	if (!is_active() || !(playing_ || in_editor_)) {
		return;
	}
	const std::string path = text(model_path_);
	if ((model_ && model_->path() == path) || (pending_model_ && pending_model_->path() == path)) {
		return;
	}
	if (path.empty()) {
		fail("model_path is empty: set it to a model package folder (the default model is " + std::string(kDefaultModelPath) + ")");
		return;
	}
	pending_model_ = acquire_model(path);
	set_process(true);
}

void MotionGenerator::poll_model() {
	if (!pending_model_ || !pending_model_->is_done()) {
		return;
	}
	std::shared_ptr<SharedModel> loaded = std::move(pending_model_);
	pending_model_.reset();
	std::shared_ptr<const ModelPackage> package = loaded->package();
	if (!package) {
		// The model that was there (if any) goes on.
		load_failed_ = true;
		fail("cannot load the model '" + loaded->path() + "': " + loaded->error());
		update_configuration_warnings();
		return;
	}
	load_failed_ = false;
	stop_planner();
	retargeter_.reset();
	rig_skeleton_id_ = 0;
	model_ = std::move(loaded);
	package_ = std::move(package);
	update_configuration_warnings();
	emit_signal("model_loaded");
}

void MotionGenerator::_enter_tree() {
	in_tree_ = true;
	skeleton_cache_id_ = 0;  // the paths may lead elsewhere from here
	target_cache_id_ = 0;
	set_process(true);
}

void MotionGenerator::_ready() {
	request_model();
}

void MotionGenerator::_exit_tree() {
	in_tree_ = false;
	// The modifier stays under the skeleton (it writes nothing while this node
	// is outside the tree) and frees itself once this node is gone.
}

PlannerConfig MotionGenerator::planner_config(const std::vector<float> &initial_history) const {
	PlannerConfig config;
	if (steps_ > 0) {
		config.steps = static_cast<size_t>(steps_);
	}
	if (text_guidance_ >= 0.0) {
		config.w_text = static_cast<float>(text_guidance_);
	}
	if (constraint_guidance_ >= 0.0) {
		config.w_con = static_cast<float>(constraint_guidance_);
	}
	if (path_guidance_scale_ >= 0.0) {
		config.path_guidance_scale = static_cast<float>(path_guidance_scale_);
	}
	if (text_only_guidance_scale_ >= 0.0) {
		config.text_only_guidance_scale = static_cast<float>(text_only_guidance_scale_);
	}
	config.history_seconds = history_seconds_;
	config.min_buffer_frames = static_cast<size_t>(replan_buffer_frames_);
	config.foot_lock = foot_lock_;
	config.seed = static_cast<uint64_t>(seed_);
	config.velocity_blend_seconds = velocity_blend_seconds_;
	config.initial_history = initial_history;
	if (!prompt_.is_empty()) {
		config.prompt = text(prompt_);
	}
	if (shared_inference_ && model_) {
		config.generator = model_->batched_generator();
	}
	return config;
}

bool MotionGenerator::start_planner(const std::vector<float> &initial_history) {
	if (!package_ || !build_rig(find_skeleton())) {
		return false;
	}
	place_anchor();
	PlannerConfig config = planner_config(initial_history);
	timeline_ids_.clear();
	timeline_start_ = 0.0;
	timeline_cycles_ = 0;
	timeline_finished_ = false;
	if (timeline_.is_valid()) {
		// In the config, so the first window already follows the timeline.
		try {
			const double length = timeline_->get_length();
			const int64_t cycles = timeline_->get_loop() && length > 0.0 ? 2 : 1;
			for (int64_t cycle = 0; cycle < cycles; ++cycle) {
				Timeline part = build_timeline(anchor_, static_cast<double>(cycle) * length, RootStart{});
				for (PromptEvent &event : part.prompts) {
					config.initial_prompts.push_back(std::move(event));
				}
				for (Constraint &constraint : part.constraints) {
					config.initial_constraints.push_back(std::move(constraint));
					timeline_ids_.push_back(config.initial_constraints.size());  // ids 1..n (PlannerConfig)
				}
			}
			timeline_cycles_ = cycles;
		} catch (const std::exception &failure) {
			fail(failure.what());
			config.initial_prompts.clear();
			config.initial_constraints.clear();
			timeline_ids_.clear();
		}
	}
	try {
		planner_ = std::make_unique<Planner>(package_, std::move(config));
	} catch (const std::exception &failure) {
		planner_.reset();
		return fail(std::string("cannot start generating: ") + failure.what());
	}
	// Goals given before the planner existed (waiting for the model) go in now.
	for (const QueuedPrompt &queued : queued_prompts_) {
		planner_->set_prompt_at(queued.time, queued.text);
	}
	queued_prompts_.clear();
	for (WorldWaypoint &waypoint : waypoints_) {
		submit(waypoint);
	}
	if (path_) {
		submit(*path_);
	}
	for (WorldJointTarget &target : joint_targets_) {
		submit(target);
	}
	for (PoseKeyframe &keyframe : keyframes_) {
		try {
			submit(keyframe);
		} catch (const std::exception &failure) {
			fail(std::string("keyframes: ") + failure.what());
		}
	}
	windows_seen_ = 0;
	last_window_id_ = 0;
	window_prompts_.clear();
	shown_window_id_ = 0;
	shown_prompt_.reset();
	has_pose_ = false;
	has_rig_pose_ = false;
	has_last_character_ = false;
	fall_speed_ = 0.0f;
	drift_since_submit_ = glm::vec2(0.0f);
	set_target_velocity(target_velocity_);
	ensure_modifier(find_skeleton());
	return true;
}

void MotionGenerator::stop_planner() {
	planner_.reset();
	has_pose_ = false;
	has_rig_pose_ = false;
}

// Resolved when the node enters the tree or a path changes, as Godot's own
// nodes cache their NodePaths: a path lookup is the dearest call of a frame.
Skeleton3D *MotionGenerator::find_skeleton() const {
	if (!in_tree_) {
		return nullptr;
	}
	if (auto *cached = Object::cast_to<Skeleton3D>(object_from_instance_id(skeleton_cache_id_))) {
		return cached;
	}
	Skeleton3D *skeleton = skeleton_path_.is_empty() ? nullptr : Object::cast_to<Skeleton3D>(get_node_or_null(skeleton_path_));
	skeleton_cache_id_ = skeleton != nullptr ? skeleton->get_instance_id() : 0;
	return skeleton;
}

Node3D *MotionGenerator::find_root_motion_target() const {
	if (root_motion_target_path_.is_empty() || !in_tree_ || in_editor_) {
		return nullptr;
	}
	if (auto *cached = Object::cast_to<Node3D>(object_from_instance_id(target_cache_id_))) {
		return cached;
	}
	auto *target = Object::cast_to<Node3D>(get_node_or_null(root_motion_target_path_));
	target_cache_id_ = target != nullptr ? target->get_instance_id() : 0;
	return target;
}

Node3D *MotionGenerator::reference_node() const {
	if (Node3D *target = find_root_motion_target()) {
		return target;
	}
	return find_skeleton();
}

bool MotionGenerator::build_rig(Skeleton3D *skeleton) {
	if (skeleton == nullptr || !package_) {
		return false;
	}
	const uint64_t bone_map_id = bone_map_.is_valid() ? bone_map_->get_instance_id() : 0;
	if (retargeter_ && rig_skeleton_id_ == skeleton->get_instance_id() && rig_version_ == skeleton->get_version() && rig_bone_map_id_ == bone_map_id) {
		return true;
	}
	retargeter_.reset();
	std::vector<RigBone> rig;
	const int32_t bones = skeleton->get_bone_count();
	for (int32_t bone = 0; bone < bones; ++bone) {
		const Frame rest = to_frame(skeleton->get_bone_rest(bone));
		rig.push_back({ text(skeleton->get_bone_name(bone)), skeleton->get_bone_parent(bone), rest.origin, rest.rotation() });
	}
	std::map<std::string, std::string> explicit_names;
	if (bone_map_.is_valid()) {
		for (const std::string &joint : package_->skeleton().names()) {
			const std::string profile = humanoid_profile_name(joint);
			if (profile.empty()) {
				continue;
			}
			const std::string bone = bone_map_->get_skeleton_bone_name(StringName(profile.c_str())).utf8();
			if (!bone.empty()) {
				explicit_names[joint] = bone;
			}
		}
	}
	try {
		retargeter_ = std::make_unique<Retargeter>(package_->skeleton(), std::move(rig), match_bones(package_->skeleton(), rig, explicit_names));
	} catch (const std::exception &failure) {
		if (!rig_failed_) {
			rig_failed_ = true;
			fail(std::string("skeleton '") + text(String(skeleton_path_)) + "': " + failure.what());
		}
		return false;
	}
	rig_failed_ = false;
	rig_skeleton_id_ = skeleton->get_instance_id();
	rig_version_ = skeleton->get_version();
	rig_bone_map_id_ = bone_map_id;
	const std::vector<std::string> unmapped = retargeter_->unmapped_joints();
	if (unmapped != unmapped_joints_) {
		unmapped_joints_ = unmapped;
		update_configuration_warnings();
	}
	return true;
}

void MotionGenerator::ensure_modifier(Skeleton3D *skeleton) {
	if (skeleton == nullptr) {
		return;
	}
	const uint64_t skeleton_id = skeleton->get_instance_id();
	if (modifier_id_ != 0 && modifier_skeleton_id_ == skeleton_id) {
		return;  // checked when it was made; a freed skeleton takes it along and changes the id
	}
	auto *modifier = Object::cast_to<MotionPoseModifier>(object_from_instance_id(modifier_id_));
	if (modifier != nullptr && modifier->get_parent() == skeleton) {
		modifier_skeleton_id_ = skeleton_id;
		return;
	}
	remove_modifier();
	modifier = memnew_object<MotionPoseModifier>();
	modifier->set_generator_id(get_instance_id());
	modifier->set_influence(influence_);
	skeleton->add_child(modifier, false, Node::INTERNAL_MODE_BACK);
	modifier_id_ = modifier->get_instance_id();
	modifier_skeleton_id_ = skeleton_id;
}

void MotionGenerator::remove_modifier() {
	// Freed by the engine at the end of the frame: its skeleton may be busy now.
	auto *modifier = Object::cast_to<MotionPoseModifier>(object_from_instance_id(modifier_id_));
	modifier_id_ = 0;
	modifier_skeleton_id_ = 0;
	if (modifier != nullptr) {
		modifier->set_generator_id(0);
		modifier->queue_free();
	}
}

void MotionGenerator::place_anchor() {
	anchor_ = make_anchor();
	anchor_placed_ = true;
}

MotionGenerator::Anchor MotionGenerator::make_anchor() const {
	Anchor anchor;
	if (Node3D *reference = reference_node()) {
		const Frame frame = to_frame(reference->get_global_transform());
		anchor.yaw_angle = frame.yaw();
		anchor.yaw = heading_rotation(anchor.yaw_angle);
		anchor.origin = frame.origin;
	}
	// Metres of the rig per metre of the model: the legs' ratio, in world units.
	if (retargeter_ && retargeter_->model_leg_length() > 0.0f && retargeter_->rig_leg_length() > 0.0f) {
		Skeleton3D *skeleton = find_skeleton();
		const float skeleton_scale = skeleton != nullptr ? to_frame(skeleton->get_global_transform()).scale() : 1.0f;
		anchor.scale = retargeter_->rig_leg_length() * skeleton_scale / retargeter_->model_leg_length();
	}
	return anchor;
}

glm::quat MotionGenerator::frame_rotation(const Skeleton3D *skeleton) const {
	return frame_rotation(skeleton != nullptr ? to_frame(skeleton->get_global_transform()).rotation() : glm::quat(1, 0, 0, 0));
}

glm::quat MotionGenerator::frame_rotation(const glm::quat &skeleton_rotation) const {
	return frame_rotation(skeleton_rotation, anchor_);
}

glm::quat MotionGenerator::frame_rotation(const glm::quat &skeleton_rotation, const Anchor &anchor) {
	// Model world -> skeleton space: the anchor's yaw, then the skeleton's world rotation undone.
	return glm::normalize(glm::inverse(skeleton_rotation) * glm::quat_cast(anchor.yaw));
}

// --- every frame ---------------------------------------------------------------------

void MotionGenerator::_process(double delta) {
	// The cost of the frame before: this _process and its pose write.
	frame_microseconds_[frame_cost_index_ % frame_microseconds_.size()] = current_frame_microseconds_;
	++frame_cost_index_;
	current_frame_microseconds_ = 0.0;
	MainThreadTimer timer(current_frame_microseconds_);
	poll_model();
	if (showing_clip_) {
		return;  // seek_clip poses the rig
	}
	if (!planner_) {
		if (package_ && is_active() && (playing_ || in_editor_)) {
			start_planner({});
		}
		if (!planner_) {
			return;
		}
	}
	// Looked up once a frame: path lookups are the dearest engine calls here.
	Skeleton3D *skeleton = find_skeleton();
	Node3D *target = find_root_motion_target();
	if (!build_rig(skeleton)) {
		return;
	}
	ensure_modifier(skeleton);
	// The motion clock starts with the first generated frame, not before it.
	if (has_pose_ && (playing_ || in_editor_)) {
		planner_->advance(std::max(0.0, delta));
	}
	report_planner();
	advance_timeline();
	has_pose_ = planner_->sample_current(pose_);
	if (!has_pose_) {
		return;
	}
	// The character's frame in the world: the root's ground point and heading.
	const glm::vec3 root_world = anchor_.to_world(glm::vec3(pose_.root_position.x, 0.0f, pose_.root_position.z));
	Frame character;
	character.basis = heading_rotation(anchor_.yaw_angle + pose_.heading);
	character.origin = root_world;
	hips_world_ = anchor_.to_world(pose_.root_position);
	apply_root_motion(delta, character, target, skeleton);
	emit_reached_goals();
}

void MotionGenerator::apply_root_motion(double delta, const Frame &character, Node3D *target, Skeleton3D *skeleton) {
	Frame body = character;
	if (target != nullptr) {
		const Frame current = to_frame(target->get_global_transform());
		const float target_scale = current.scale();
		if (auto *character_body = Object::cast_to<CharacterBody3D>(target)) {
			const glm::vec3 step = has_last_character_ ? character.origin - last_character_origin_ : glm::vec3(0.0f);
			const float seconds = static_cast<float>(std::max(delta, 1e-6));
			const glm::vec3 gravity = to_glm(character_body->get_gravity());
			if (character_body->is_on_floor()) {
				fall_speed_ = 0.0f;
			}
			fall_speed_ += gravity.y * seconds;
			character_body->set_velocity(Vector3{ step.x / seconds, fall_speed_, step.z / seconds });
			Transform3D turned = character_body->get_global_transform();
			turned.basis = to_godot(character.basis * target_scale);
			character_body->set_global_transform(turned);
			character_body->move_and_slide();
			body = to_frame(character_body->get_global_transform());
			// Held back (or pushed): the motion goes on from where the body is.
			const glm::vec2 drift(body.origin.x - character.origin.x, body.origin.z - character.origin.z);
			if (glm::length(drift) > 1e-4f) {
				anchor_.origin.x += drift.x;
				anchor_.origin.z += drift.y;
				drift_since_submit_ += drift;
				const double now = get_time();
				if (glm::length(drift_since_submit_) > kResubmitDrift && now - last_submit_time_ > kResubmitInterval) {
					drift_since_submit_ = glm::vec2(0.0f);
					last_submit_time_ = now;
					submit_world_goals();
				}
			}
			last_character_origin_ = character.origin + glm::vec3(drift.x, 0.0f, drift.y);
		} else {
			Frame placed = character;
			placed.basis = character.basis * target_scale;
			placed.origin.y = current.origin.y;
			target->set_global_transform(to_godot(placed));
			body = placed;
			last_character_origin_ = character.origin;
		}
		has_last_character_ = true;
	}
	update_rig_pose(body, character, target != nullptr, skeleton);
}

void MotionGenerator::update_rig_pose(const Frame &body, const Frame &character, bool moved_target, Skeleton3D *skeleton) {
	if (skeleton == nullptr || !retargeter_) {
		has_rig_pose_ = false;
		return;
	}
	const Frame skeleton_frame = to_frame(skeleton->get_global_transform());
	const glm::quat skeleton_rotation = skeleton_frame.rotation();
	glm::vec3 hips_world = hips_world_;
	glm::quat frame = frame_rotation(skeleton_rotation);
	if (moved_target) {
		// The pose relative to the character's frame, shown where the body is.
		const glm::vec3 relative = glm::inverse(character.rotation()) * (hips_world_ - character.origin);
		hips_world = body.origin + body.rotation() * relative;
		frame = frame_rotation(glm::inverse(body.rotation() * glm::inverse(character.rotation())) * skeleton_rotation);
	}
	retargeter_->apply(pose_.local_rotations, frame, skeleton_frame.apply_inverse(hips_world), rig_pose_);
	has_rig_pose_ = true;
	posed_skeleton_ = skeleton;
}

void MotionGenerator::write_pose(Skeleton3D *skeleton) {
	MainThreadTimer timer(current_frame_microseconds_);
	// Only the skeleton this frame's pose was made for (the rig's bones are known from then).
	if (!has_rig_pose_ || !in_tree_ || skeleton == nullptr || skeleton != posed_skeleton_ || !retargeter_) {
		return;
	}
	for (size_t bone = 0; bone < rig_pose_.local_rotations.size(); ++bone) {
		if (rig_pose_.written[bone]) {
			skeleton->set_bone_pose_rotation(static_cast<int32_t>(bone), to_godot(rig_pose_.local_rotations[bone]));
		}
	}
	skeleton->set_bone_pose_position(retargeter_->root_bone(), to_godot(rig_pose_.root_position));
}

void MotionGenerator::report_planner() {
	std::string error;
	while (planner_->pop_error(error)) {
		if (error != last_worker_error_) {  // the same failure window after window is said once
			last_worker_error_ = error;
			fail(error);
		}
	}
	const PlannerStats stats = planner_->stats();
	if (stats.windows_published == windows_seen_) {
		return;
	}
	windows_seen_ = stats.windows_published;
	for (const WindowRecord &record : planner_->window_log()) {
		if (record.id <= last_window_id_ || record.outcome != WindowOutcome::published) {
			continue;
		}
		last_window_id_ = record.id;
		last_latency_ms_ = record.latency_seconds * 1000.0;
		latencies_ms_.push_back(last_latency_ms_);
		if (latencies_ms_.size() > kLatencySamples) {
			latencies_ms_.pop_front();
		}
		window_prompts_.push_back({ record.id, record.prompt.value_or("") });
		if (window_prompts_.size() > 64) {
			window_prompts_.pop_front();
		}
		emit_signal("window_generated", last_latency_ms_, static_cast<int64_t>(record.frames));
	}
}

void MotionGenerator::emit_reached_goals() {
	// prompt_started: the first shown frame of a window made with another prompt.
	if (pose_.window_id != shown_window_id_) {
		shown_window_id_ = pose_.window_id;
		for (const ShownWindow &window : window_prompts_) {
			if (window.id == shown_window_id_) {
				if (!window.prompt.empty() && (!shown_prompt_ || *shown_prompt_ != window.prompt)) {
					emit_signal("prompt_started", String(window.prompt));
				}
				shown_prompt_ = window.prompt;
				break;
			}
		}
	}
	const double now = get_time();
	for (size_t index = 0; index < waypoints_.size(); ++index) {
		WorldWaypoint &waypoint = waypoints_[index];
		if (waypoint.reached) {
			continue;
		}
		const glm::vec2 offset(hips_world_.x - waypoint.position.x, hips_world_.z - waypoint.position.z);
		if (glm::length(offset) <= waypoint_reach_distance_) {
			waypoint.reached = true;
			emit_signal("waypoint_reached", static_cast<int64_t>(index));
		}
	}
	for (size_t index = 0; index < keyframes_.size(); ++index) {
		PoseKeyframe &keyframe = keyframes_[index];
		if (!keyframe.reached && now >= keyframe.time) {
			keyframe.reached = true;
			emit_signal("keyframe_reached", static_cast<int64_t>(index));
		}
	}
}

PackedStringArray MotionGenerator::_get_configuration_warnings() const {
	PackedStringArray warnings;
	if (model_path_.is_empty()) {
		warnings.push_back(String(std::string("Set model_path to a model package folder (the default model is ") + kDefaultModelPath + ")."));
	} else if (load_failed_) {
		warnings.push_back(String("The model did not load: " + last_error_));
	}
	if (skeleton_path_.is_empty()) {
		warnings.push_back(String("Set skeleton to the Skeleton3D this node animates."));
	} else if (is_inside_tree() && find_skeleton() == nullptr) {
		warnings.push_back(String("skeleton does not point to a Skeleton3D."));
	}
	if (!unmapped_joints_.empty()) {
		std::string names;
		for (const std::string &name : unmapped_joints_) {
			names += (names.empty() ? "" : ", ") + name;
		}
		warnings.push_back(String("Model joints without a bone in the skeleton (set bone_map): " + names + "."));
	}
	if (!root_motion_target_path_.is_empty() && is_inside_tree() && Object::cast_to<Node3D>(get_node_or_null(root_motion_target_path_)) == nullptr) {
		warnings.push_back(String("root_motion_target does not point to a Node3D."));
	}
	return warnings;
}

void MotionGenerator::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_model_path", "path"), &MotionGenerator::set_model_path);
	ClassDB::bind_method(D_METHOD("get_model_path"), &MotionGenerator::get_model_path);
	ClassDB::bind_method(D_METHOD("set_skeleton", "path"), &MotionGenerator::set_skeleton);
	ClassDB::bind_method(D_METHOD("get_skeleton"), &MotionGenerator::get_skeleton);
	ClassDB::bind_method(D_METHOD("set_bone_map", "bone_map"), &MotionGenerator::set_bone_map);
	ClassDB::bind_method(D_METHOD("get_bone_map"), &MotionGenerator::get_bone_map);
	ClassDB::bind_method(D_METHOD("set_root_motion_target", "path"), &MotionGenerator::set_root_motion_target);
	ClassDB::bind_method(D_METHOD("get_root_motion_target"), &MotionGenerator::get_root_motion_target);
	ClassDB::bind_method(D_METHOD("set_influence", "influence"), &MotionGenerator::set_influence);
	ClassDB::bind_method(D_METHOD("get_influence"), &MotionGenerator::get_influence);
	ClassDB::bind_method(D_METHOD("set_prompt", "prompt"), &MotionGenerator::set_prompt);
	ClassDB::bind_method(D_METHOD("get_prompt"), &MotionGenerator::get_prompt);
	ClassDB::bind_method(D_METHOD("set_playing", "playing"), &MotionGenerator::set_playing);
	ClassDB::bind_method(D_METHOD("is_playing"), &MotionGenerator::is_playing);
	ClassDB::bind_method(D_METHOD("set_steps", "steps"), &MotionGenerator::set_steps);
	ClassDB::bind_method(D_METHOD("get_steps"), &MotionGenerator::get_steps);
	ClassDB::bind_method(D_METHOD("set_text_guidance", "weight"), &MotionGenerator::set_text_guidance);
	ClassDB::bind_method(D_METHOD("get_text_guidance"), &MotionGenerator::get_text_guidance);
	ClassDB::bind_method(D_METHOD("set_constraint_guidance", "weight"), &MotionGenerator::set_constraint_guidance);
	ClassDB::bind_method(D_METHOD("get_constraint_guidance"), &MotionGenerator::get_constraint_guidance);
	ClassDB::bind_method(D_METHOD("set_path_guidance_scale", "scale"), &MotionGenerator::set_path_guidance_scale);
	ClassDB::bind_method(D_METHOD("get_path_guidance_scale"), &MotionGenerator::get_path_guidance_scale);
	ClassDB::bind_method(D_METHOD("set_text_only_guidance_scale", "scale"), &MotionGenerator::set_text_only_guidance_scale);
	ClassDB::bind_method(D_METHOD("get_text_only_guidance_scale"), &MotionGenerator::get_text_only_guidance_scale);
	ClassDB::bind_method(D_METHOD("set_seed", "seed"), &MotionGenerator::set_seed);
	ClassDB::bind_method(D_METHOD("get_seed"), &MotionGenerator::get_seed);
	ClassDB::bind_method(D_METHOD("set_history_seconds", "seconds"), &MotionGenerator::set_history_seconds);
	ClassDB::bind_method(D_METHOD("get_history_seconds"), &MotionGenerator::get_history_seconds);
	ClassDB::bind_method(D_METHOD("set_replan_buffer_frames", "frames"), &MotionGenerator::set_replan_buffer_frames);
	ClassDB::bind_method(D_METHOD("get_replan_buffer_frames"), &MotionGenerator::get_replan_buffer_frames);
	ClassDB::bind_method(D_METHOD("set_foot_lock", "enabled"), &MotionGenerator::set_foot_lock);
	ClassDB::bind_method(D_METHOD("get_foot_lock"), &MotionGenerator::get_foot_lock);
	ClassDB::bind_method(D_METHOD("set_velocity_blend_seconds", "seconds"), &MotionGenerator::set_velocity_blend_seconds);
	ClassDB::bind_method(D_METHOD("get_velocity_blend_seconds"), &MotionGenerator::get_velocity_blend_seconds);
	ClassDB::bind_method(D_METHOD("set_shared_inference", "shared"), &MotionGenerator::set_shared_inference);
	ClassDB::bind_method(D_METHOD("get_shared_inference"), &MotionGenerator::get_shared_inference);
	ClassDB::bind_method(D_METHOD("set_target_velocity", "velocity"), &MotionGenerator::set_target_velocity);
	ClassDB::bind_method(D_METHOD("get_target_velocity"), &MotionGenerator::get_target_velocity);
	ClassDB::bind_method(D_METHOD("set_waypoint_reach_distance", "metres"), &MotionGenerator::set_waypoint_reach_distance);
	ClassDB::bind_method(D_METHOD("get_waypoint_reach_distance"), &MotionGenerator::get_waypoint_reach_distance);
	ClassDB::bind_method(D_METHOD("set_preview_in_editor", "preview"), &MotionGenerator::set_preview_in_editor);
	ClassDB::bind_method(D_METHOD("get_preview_in_editor"), &MotionGenerator::get_preview_in_editor);

	ClassDB::bind_method(D_METHOD("set_waypoints", "waypoints"), &MotionGenerator::set_waypoints);
	ClassDB::bind_method(D_METHOD("get_waypoints"), &MotionGenerator::get_waypoints);
	ClassDB::bind_method(D_METHOD("set_keyframes", "keyframes"), &MotionGenerator::set_keyframes);
	ClassDB::bind_method(D_METHOD("get_keyframes"), &MotionGenerator::get_keyframes);
	ClassDB::bind_method(D_METHOD("queue_prompt", "text", "at_seconds"), &MotionGenerator::queue_prompt);
	ClassDB::bind_method(D_METHOD("clear_prompts"), &MotionGenerator::clear_prompts);
	ClassDB::bind_method(D_METHOD("add_waypoint", "position", "at_seconds", "heading"), &MotionGenerator::add_waypoint, DEFVAL(NAN));
	ClassDB::bind_method(D_METHOD("clear_waypoints"), &MotionGenerator::clear_waypoints);
	ClassDB::bind_method(D_METHOD("set_path", "path", "speed"), &MotionGenerator::set_path);
	ClassDB::bind_method(D_METHOD("add_pose_keyframe", "pose", "at_seconds"), &MotionGenerator::add_pose_keyframe);
	ClassDB::bind_method(D_METHOD("add_joint_target", "bone", "at_seconds", "position", "rotation"), &MotionGenerator::add_joint_target,
			DEFVAL(Variant()), DEFVAL(Variant()));
	ClassDB::bind_method(D_METHOD("clear_constraints"), &MotionGenerator::clear_constraints);
	ClassDB::bind_method(D_METHOD("reset", "pose"), &MotionGenerator::reset, DEFVAL(Variant()));
	ClassDB::bind_method(D_METHOD("get_time"), &MotionGenerator::get_time);
	ClassDB::bind_method(D_METHOD("get_stats"), &MotionGenerator::get_stats);
	ClassDB::bind_method(D_METHOD("get_planned_root", "at_seconds"), &MotionGenerator::get_planned_root);
	ClassDB::bind_method(D_METHOD("get_joint_names"), &MotionGenerator::get_joint_names);
	ClassDB::bind_method(D_METHOD("get_model_sampling"), &MotionGenerator::get_model_sampling);
	ClassDB::bind_method(D_METHOD("is_model_loaded"), &MotionGenerator::is_model_loaded);
	ClassDB::bind_method(D_METHOD("is_generating"), &MotionGenerator::is_generating);
	ClassDB::bind_method(D_METHOD("get_last_error"), &MotionGenerator::get_last_error);
	ClassDB::bind_method(D_METHOD("set_timeline", "timeline"), &MotionGenerator::set_timeline);
	ClassDB::bind_method(D_METHOD("get_timeline"), &MotionGenerator::get_timeline);
	ClassDB::bind_method(D_METHOD("generate_clip", "seconds"), &MotionGenerator::generate_clip, DEFVAL(-1.0));
	ClassDB::bind_method(D_METHOD("has_clip"), &MotionGenerator::has_clip);
	ClassDB::bind_method(D_METHOD("get_clip_length"), &MotionGenerator::get_clip_length);
	ClassDB::bind_method(D_METHOD("clear_clip"), &MotionGenerator::clear_clip);
	ClassDB::bind_method(D_METHOD("seek_clip", "seconds"), &MotionGenerator::seek_clip);
	ClassDB::bind_method(D_METHOD("get_clip_root", "seconds"), &MotionGenerator::get_clip_root);
	ClassDB::bind_method(D_METHOD("bake_animation", "seconds", "fps", "root_node"), &MotionGenerator::bake_animation, DEFVAL(-1.0), DEFVAL(30.0),
			DEFVAL(Variant()));
	ClassDB::bind_method(D_METHOD("export_bvh", "path", "seconds"), &MotionGenerator::export_bvh, DEFVAL(-1.0));
	ClassDB::bind_method(D_METHOD("timeline_to_json"), &MotionGenerator::timeline_to_json);
	ClassDB::bind_method(D_METHOD("timeline_from_json", "json"), &MotionGenerator::timeline_from_json);

	ADD_GROUP("Model", "");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "model_path", PROPERTY_HINT_DIR), "set_model_path", "get_model_path");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "shared_inference"), "set_shared_inference", "get_shared_inference");
	ADD_GROUP("Target", "");
	ADD_PROPERTY(PropertyInfo(Variant::NODE_PATH, "skeleton", PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Skeleton3D"), "set_skeleton", "get_skeleton");
	ADD_PROPERTY(PropertyInfo(Variant::OBJECT, "bone_map", PROPERTY_HINT_RESOURCE_TYPE, "BoneMap", PROPERTY_USAGE_DEFAULT, "BoneMap"), "set_bone_map", "get_bone_map");
	ADD_PROPERTY(PropertyInfo(Variant::NODE_PATH, "root_motion_target", PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"), "set_root_motion_target", "get_root_motion_target");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "influence", PROPERTY_HINT_RANGE, "0,1,0.01"), "set_influence", "get_influence");
	ADD_GROUP("Generation", "");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "prompt", PROPERTY_HINT_MULTILINE_TEXT), "set_prompt", "get_prompt");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "playing"), "set_playing", "is_playing");
	ADD_PROPERTY(PropertyInfo(Variant::VECTOR3, "target_velocity", PROPERTY_HINT_NONE, "suffix:m/s"), "set_target_velocity", "get_target_velocity");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "foot_lock"), "set_foot_lock", "get_foot_lock");
	ADD_GROUP("Goals", "");
	ADD_PROPERTY(PropertyInfo(Variant::OBJECT, "timeline", PROPERTY_HINT_RESOURCE_TYPE, "MotionTimeline", PROPERTY_USAGE_DEFAULT, "MotionTimeline"), "set_timeline",
			"get_timeline");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "waypoints", PROPERTY_HINT_TYPE_STRING, "24/17:MotionWaypoint"), "set_waypoints", "get_waypoints");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "keyframes", PROPERTY_HINT_TYPE_STRING, "24/17:MotionKeyframe"), "set_keyframes", "get_keyframes");
	ADD_GROUP("Sampling", "");
	ADD_PROPERTY(PropertyInfo(Variant::INT, "steps", PROPERTY_HINT_RANGE, "0,50,1,or_greater"), "set_steps", "get_steps");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "text_guidance", PROPERTY_HINT_RANGE, "-1,10,0.1,or_greater"), "set_text_guidance", "get_text_guidance");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "constraint_guidance", PROPERTY_HINT_RANGE, "-1,10,0.1,or_greater"), "set_constraint_guidance",
			"get_constraint_guidance");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "path_guidance_scale", PROPERTY_HINT_RANGE, "-1,1,0.05"), "set_path_guidance_scale",
			"get_path_guidance_scale");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "text_only_guidance_scale", PROPERTY_HINT_RANGE, "-1,4,0.05"), "set_text_only_guidance_scale",
			"get_text_only_guidance_scale");
	ADD_PROPERTY(PropertyInfo(Variant::INT, "seed"), "set_seed", "get_seed");
	ADD_GROUP("Streaming", "");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "history_seconds", PROPERTY_HINT_RANGE, "0,8,0.2,suffix:s"), "set_history_seconds", "get_history_seconds");
	ADD_PROPERTY(PropertyInfo(Variant::INT, "replan_buffer_frames", PROPERTY_HINT_RANGE, "0,40,1,or_greater"), "set_replan_buffer_frames",
			"get_replan_buffer_frames");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "velocity_blend_seconds", PROPERTY_HINT_RANGE, "0.05,2,0.05,suffix:s"), "set_velocity_blend_seconds",
			"get_velocity_blend_seconds");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "waypoint_reach_distance", PROPERTY_HINT_RANGE, "0.05,2,0.05,suffix:m"), "set_waypoint_reach_distance",
			"get_waypoint_reach_distance");
	ADD_GROUP("Editor", "");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "preview_in_editor"), "set_preview_in_editor", "get_preview_in_editor");

	ADD_SIGNAL(MethodInfo("window_generated", PropertyInfo(Variant::FLOAT, "latency_ms"), PropertyInfo(Variant::INT, "frames")));
	ADD_SIGNAL(MethodInfo("prompt_started", PropertyInfo(Variant::STRING, "text")));
	ADD_SIGNAL(MethodInfo("waypoint_reached", PropertyInfo(Variant::INT, "index")));
	ADD_SIGNAL(MethodInfo("keyframe_reached", PropertyInfo(Variant::INT, "index")));
	ADD_SIGNAL(MethodInfo("generation_failed", PropertyInfo(Variant::STRING, "message")));
	ADD_SIGNAL(MethodInfo("model_loaded"));
	ADD_SIGNAL(MethodInfo("timeline_finished"));
}

} // namespace ardy
