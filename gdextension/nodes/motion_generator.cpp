#include "motion_generator.hpp"

#include "motion_goals.hpp"
#include "motion_pose_modifier.hpp"

#include "godot/error_macros.hpp"
#include "godot/ref.hpp"

#include "features.hpp"
#include "generation_cpu.hpp"
#include "kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <map>

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
				constraint_guidance_ >= 0.0 ? static_cast<float>(constraint_guidance_) : defaults.w_con);
	} catch (const std::exception &failure) {
		return fail(std::string(what) + ": " + failure.what());
	}
	return true;
}

int64_t MotionGenerator::get_steps() const {
	return steps_;
}

void MotionGenerator::set_text_guidance(double weight) {
	if (!std::isfinite(weight)) {
		fail("text_guidance: not a finite number");
		return;
	}
	const double previous = text_guidance_;
	text_guidance_ = weight;
	if (!apply_sampling("text_guidance")) {
		text_guidance_ = previous;
	}
}

double MotionGenerator::get_text_guidance() const {
	return text_guidance_;
}

void MotionGenerator::set_constraint_guidance(double weight) {
	if (!std::isfinite(weight)) {
		fail("constraint_guidance: not a finite number");
		return;
	}
	const double previous = constraint_guidance_;
	constraint_guidance_ = weight;
	if (!apply_sampling("constraint_guidance")) {
		constraint_guidance_ = previous;
	}
}

double MotionGenerator::get_constraint_guidance() const {
	return constraint_guidance_;
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
		planner_->clear_prompt();
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
	try {
		planner_ = std::make_unique<Planner>(package_, planner_config(initial_history));
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
	anchor_ = Anchor();
	if (Node3D *reference = reference_node()) {
		const Frame frame = to_frame(reference->get_global_transform());
		anchor_.yaw_angle = frame.yaw();
		anchor_.yaw = heading_rotation(anchor_.yaw_angle);
		anchor_.origin = frame.origin;
	}
	// Metres of the rig per metre of the model: the legs' ratio, in world units.
	if (retargeter_ && retargeter_->model_leg_length() > 0.0f && retargeter_->rig_leg_length() > 0.0f) {
		Skeleton3D *skeleton = find_skeleton();
		const float skeleton_scale = skeleton != nullptr ? to_frame(skeleton->get_global_transform()).scale() : 1.0f;
		anchor_.scale = retargeter_->rig_leg_length() * skeleton_scale / retargeter_->model_leg_length();
	}
	anchor_placed_ = true;
}

glm::quat MotionGenerator::frame_rotation(const Skeleton3D *skeleton) const {
	return frame_rotation(skeleton != nullptr ? to_frame(skeleton->get_global_transform()).rotation() : glm::quat(1, 0, 0, 0));
}

glm::quat MotionGenerator::frame_rotation(const glm::quat &skeleton_rotation) const {
	// Model world -> skeleton space: the anchor's yaw, then the skeleton's world rotation undone.
	return glm::normalize(glm::inverse(skeleton_rotation) * glm::quat_cast(anchor_.yaw));
}

// --- every frame ---------------------------------------------------------------------

void MotionGenerator::_process(double delta) {
	// The cost of the frame before: this _process and its pose write.
	frame_microseconds_[frame_cost_index_ % frame_microseconds_.size()] = current_frame_microseconds_;
	++frame_cost_index_;
	current_frame_microseconds_ = 0.0;
	MainThreadTimer timer(current_frame_microseconds_);
	poll_model();
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
	ClassDB::bind_method(D_METHOD("is_model_loaded"), &MotionGenerator::is_model_loaded);
	ClassDB::bind_method(D_METHOD("is_generating"), &MotionGenerator::is_generating);
	ClassDB::bind_method(D_METHOD("get_last_error"), &MotionGenerator::get_last_error);

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
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "waypoints", PROPERTY_HINT_TYPE_STRING, "24/17:MotionWaypoint"), "set_waypoints", "get_waypoints");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "keyframes", PROPERTY_HINT_TYPE_STRING, "24/17:MotionKeyframe"), "set_keyframes", "get_keyframes");
	ADD_GROUP("Sampling", "");
	ADD_PROPERTY(PropertyInfo(Variant::INT, "steps", PROPERTY_HINT_RANGE, "0,50,1,or_greater"), "set_steps", "get_steps");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "text_guidance", PROPERTY_HINT_RANGE, "-1,10,0.1,or_greater"), "set_text_guidance", "get_text_guidance");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "constraint_guidance", PROPERTY_HINT_RANGE, "-1,10,0.1,or_greater"), "set_constraint_guidance",
			"get_constraint_guidance");
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
}

} // namespace ardy
