#pragma once
// MotionGenerator: the node game developers drop into a scene. It owns one
// streaming Planner (src/planner.hpp) fed from its properties and methods;
// every frame it advances the planner, samples the pose, moves the root
// motion target and hands the retargeted pose to a MotionPoseModifier, the
// SkeletonModifier3D it keeps under the skeleton, which writes it in the
// skeleton's update. Nothing on the main thread waits for inference.
//
// Spaces. The planner has its own world ("model space"); the node maps it to
// Godot's world by an anchor: world = origin + yaw * (scale * model), scale
// being the rig's leg length over the model's. World-space goals are kept
// as given and converted with the anchor; when a CharacterBody3D is held
// back by collisions the anchor moves with the body and the goals are sent
// again, so they are still reached from where the body is.
#include "godot/class_db.hpp"

#include "convert.hpp"
#include "model_cache.hpp"
#include "motion_timeline.hpp"
#include "offline_motion.hpp"
#include "planner.hpp"
#include "retarget.hpp"
#include "timeline.hpp"

#include <array>
#include <chrono>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace ardy {

class MotionPoseModifier;

class MotionGenerator : public godot::Node3D {
	GDCLASS(MotionGenerator, godot::Node3D)

public:
	static constexpr const char *kDefaultModelPath = "res://addons/ardy/models/default";

	MotionGenerator();
	~MotionGenerator() override;

	// --- properties ---
	void set_model_path(const godot::String &path);
	godot::String get_model_path() const;
	void set_skeleton(const godot::NodePath &path);
	godot::NodePath get_skeleton() const;
	void set_bone_map(const godot::Ref<godot::BoneMap> &bone_map);
	godot::Ref<godot::BoneMap> get_bone_map() const;
	void set_root_motion_target(const godot::NodePath &path);
	godot::NodePath get_root_motion_target() const;
	void set_influence(double influence);
	double get_influence() const;
	void set_prompt(const godot::String &prompt);
	godot::String get_prompt() const;
	void set_playing(bool playing);
	bool is_playing() const;
	void set_steps(int64_t steps);
	int64_t get_steps() const;
	void set_text_guidance(double weight);
	double get_text_guidance() const;
	void set_constraint_guidance(double weight);
	double get_constraint_guidance() const;
	void set_path_guidance_scale(double scale);
	double get_path_guidance_scale() const;
	void set_text_only_guidance_scale(double scale);
	double get_text_only_guidance_scale() const;
	void set_seed(int64_t seed);
	int64_t get_seed() const;
	void set_history_seconds(double seconds);
	double get_history_seconds() const;
	void set_replan_buffer_frames(int64_t frames);
	int64_t get_replan_buffer_frames() const;
	void set_foot_lock(bool enabled);
	bool get_foot_lock() const;
	void set_velocity_blend_seconds(double seconds);
	double get_velocity_blend_seconds() const;
	void set_shared_inference(bool shared);
	bool get_shared_inference() const;
	void set_target_velocity(const godot::Vector3 &velocity);
	godot::Vector3 get_target_velocity() const;
	void set_waypoint_reach_distance(double metres);
	double get_waypoint_reach_distance() const;
	void set_preview_in_editor(bool preview);
	bool get_preview_in_editor() const;
	void set_timeline(const godot::Ref<MotionTimeline> &timeline);
	godot::Ref<MotionTimeline> get_timeline() const;

	void set_waypoints(const godot::Array &waypoints);
	godot::Array get_waypoints() const;
	void set_keyframes(const godot::Array &keyframes);
	godot::Array get_keyframes() const;

	// --- methods ---
	void queue_prompt(const godot::String &text, double at_seconds);
	void clear_prompts();
	void add_waypoint(const godot::Vector3 &position, double at_seconds, double heading);
	void clear_waypoints();
	void set_path(const godot::Variant &path, double speed);
	void add_pose_keyframe(const godot::Variant &pose, double at_seconds);
	void add_joint_target(const godot::String &bone, double at_seconds, const godot::Variant &position, const godot::Variant &rotation);
	void clear_constraints();
	void reset(const godot::Variant &pose);
	double get_time() const;
	godot::Variant get_planned_root(double at_seconds) const;
	godot::Dictionary get_stats() const;
	godot::PackedStringArray get_joint_names() const;
	godot::Dictionary get_model_sampling() const;
	bool is_model_loaded() const;
	bool is_generating() const;
	godot::String get_last_error() const;

	// --- the clip: the timeline generated ahead of time (offline_motion.hpp) ---
	bool generate_clip(double seconds);
	bool has_clip() const;
	double get_clip_length() const;
	void clear_clip();
	void seek_clip(double seconds);
	godot::Variant get_clip_root(double seconds) const;
	godot::Variant bake_animation(double seconds, double fps, godot::Node *root_node);
	int64_t export_bvh(const godot::String &path, double seconds);
	godot::String timeline_to_json();
	godot::Variant timeline_from_json(const godot::String &json);

	// Called by the pose modifier in the skeleton's update.
	void write_pose(godot::Skeleton3D *skeleton);

	void _ready();
	void _enter_tree();
	void _exit_tree();
	void _process(double delta);
	godot::PackedStringArray _get_configuration_warnings() const;

protected:
	static void _bind_methods();

private:
	struct Anchor {
		glm::mat3 yaw{ 1.0f };
		float yaw_angle = 0.0f;
		glm::vec3 origin{ 0.0f };
		float scale = 1.0f;
		glm::vec3 to_world(const glm::vec3 &model) const { return origin + yaw * (scale * model); }
		glm::vec3 to_model(const glm::vec3 &world) const { return glm::transpose(yaw) * (world - origin) / scale; }
	};
	struct WorldWaypoint {
		glm::vec3 position{ 0.0f };
		double time = 0.0;
		std::optional<double> heading;  // world yaw
		Planner::ConstraintId id = 0;
		bool reached = false;
	};
	struct WorldPath {
		std::vector<glm::vec3> points;
		double start_time = 0.0;
		double speed = 1.0;
		Planner::ConstraintId id = 0;
	};
	struct WorldJointTarget {
		std::string joint;
		double time = 0.0;
		std::optional<glm::vec3> position;  // world
		std::optional<glm::quat> rotation;  // model world
		Planner::ConstraintId id = 0;
	};
	struct PoseKeyframe {
		double time = 0.0;
		godot::Dictionary pose;  // rig bone name -> local rotation
		Planner::ConstraintId id = 0;
		bool reached = false;
	};
	struct QueuedPrompt {
		double time = 0.0;
		std::string text;
	};
	struct ShownWindow {
		uint64_t id = 0;
		std::string prompt;
	};
	// Where the character is in model space when a timeline starts: the
	// root's ground position and heading at that frame.
	struct RootStart {
		int64_t frame = 0;
		glm::dvec2 position{ 0.0 };
		double heading = 0.0;
	};
	struct Clip {
		OfflineMotion motion;
		Anchor anchor;  // model space -> world when it was made
	};

	bool is_active() const;  // generates now (in game, or previewing in the editor)
	void request_model();
	void poll_model();
	bool start_planner(const std::vector<float> &initial_history);
	void stop_planner();
	bool build_rig(godot::Skeleton3D *skeleton);
	void ensure_modifier(godot::Skeleton3D *skeleton);
	void remove_modifier();
	godot::Skeleton3D *find_skeleton() const;
	godot::Node3D *find_root_motion_target() const;
	godot::Node3D *reference_node() const;
	void place_anchor();
	Anchor make_anchor() const;
	// The timeline (and the prompt property from `offset`) as model-space
	// prompts and constraints, its times shifted by `offset` seconds. Error names the item.
	Timeline build_timeline(const Anchor &anchor, double offset, const RootStart &start) const;
	void start_timeline_cycle(double offset);  // sends one cycle to the running planner
	void advance_timeline();                   // loops and reports the end, every frame
	bool load_model_now(const char *what);     // waits for the model and builds the rig
	void rig_pose_at(const Clip &clip, double seconds, godot::Skeleton3D *skeleton, Pose &pose, RigPose &rig_pose) const;
	PlannerConfig planner_config(const std::vector<float> &initial_history) const;
	bool apply_sampling(const char *what);  // false (reported) when the planner refuses them
	void change_sampling(double &field, double value, const char *what);
	void submit_world_goals();
	void clear_goal_lists();
	void submit(WorldWaypoint &waypoint);
	void submit(WorldPath &path);
	void submit(WorldJointTarget &target);
	void submit(PoseKeyframe &keyframe);
	// Replaces a goal list, taking the old goals out of the planner and sending the new ones still ahead.
	template <class Goal>
	void replace_goals(std::vector<Goal> &goals, std::vector<Goal> replacement);
	void apply_root_motion(double delta, const Frame &character, godot::Node3D *target, godot::Skeleton3D *skeleton);
	void update_rig_pose(const Frame &body, const Frame &character, bool moved_target, godot::Skeleton3D *skeleton);
	void report_planner();
	void emit_reached_goals();
	std::vector<glm::quat> rig_pose_of(const godot::Variant &pose, const char *what) const;
	// A rig pose as the model's, standing on the ground, turned to `heading` when given.
	Pose standing_pose(const godot::Variant &pose, const char *what, std::optional<float> heading) const;
	glm::quat frame_rotation(const godot::Skeleton3D *skeleton) const;
	glm::quat frame_rotation(const glm::quat &skeleton_rotation) const;
	static glm::quat frame_rotation(const glm::quat &skeleton_rotation, const Anchor &anchor);
	std::optional<std::string> model_joint_of(const godot::String &bone) const;
	double check_time(double at_seconds, const char *what) const;
	bool fail(const std::string &message);

	godot::String model_path_;
	godot::NodePath skeleton_path_;
	godot::Ref<godot::BoneMap> bone_map_;
	godot::NodePath root_motion_target_path_;
	double influence_ = 1.0;
	godot::String prompt_;
	bool playing_ = false;
	int64_t steps_ = 0;
	double text_guidance_ = -1.0;
	double constraint_guidance_ = -1.0;
	double path_guidance_scale_ = -1.0;
	double text_only_guidance_scale_ = -1.0;
	int64_t seed_ = 0;
	double history_seconds_ = 4.0;
	int64_t replan_buffer_frames_ = 4;
	bool foot_lock_ = true;
	double velocity_blend_seconds_ = 0.3;
	bool shared_inference_ = true;
	godot::Vector3 target_velocity_;
	double waypoint_reach_distance_ = 0.3;
	bool preview_in_editor_ = false;
	const bool in_editor_;  // running inside the editor (Engine.is_editor_hint())

	// Destroyed in reverse order: the planner before the model it uses.
	std::shared_ptr<SharedModel> model_;          // loaded, in use
	std::shared_ptr<SharedModel> pending_model_;  // loading, swapped in when done
	std::shared_ptr<const ModelPackage> package_;
	std::unique_ptr<Retargeter> retargeter_;
	std::unique_ptr<Planner> planner_;

	uint64_t modifier_id_ = 0;
	uint64_t modifier_skeleton_id_ = 0;     // the skeleton the modifier was put under
	godot::Skeleton3D *posed_skeleton_ = nullptr;  // the skeleton rig_pose_ was made for (compared, never used)
	bool in_tree_ = false;
	mutable uint64_t skeleton_cache_id_ = 0;  // the node skeleton_path_ led to (find_skeleton)
	mutable uint64_t target_cache_id_ = 0;    // and root_motion_target_path_
	uint64_t rig_skeleton_id_ = 0;
	uint64_t rig_version_ = 0;
	uint64_t rig_bone_map_id_ = 0;
	std::vector<std::string> unmapped_joints_;
	bool rig_failed_ = false;

	Anchor anchor_;
	bool anchor_placed_ = false;
	glm::vec3 last_character_origin_{ 0.0f };
	bool has_last_character_ = false;
	float fall_speed_ = 0.0f;
	glm::vec2 drift_since_submit_{ 0.0f };
	double last_submit_time_ = 0.0;

	Pose pose_;
	bool has_pose_ = false;
	RigPose rig_pose_;
	bool has_rig_pose_ = false;
	glm::vec3 hips_world_{ 0.0f };

	std::vector<WorldWaypoint> waypoints_;
	std::optional<WorldPath> path_;
	std::vector<WorldJointTarget> joint_targets_;
	std::vector<PoseKeyframe> keyframes_;
	std::vector<QueuedPrompt> queued_prompts_;  // queued before the planner started
	godot::Array waypoint_resources_;            // MotionWaypoint, as saved with the scene
	godot::Array keyframe_resources_;            // MotionKeyframe

	godot::Ref<MotionTimeline> timeline_;
	double timeline_start_ = 0.0;  // motion-clock seconds the timeline's time 0 is at
	int64_t timeline_cycles_ = 0;  // cycles sent to the planner
	bool timeline_finished_ = false;
	std::vector<Planner::ConstraintId> timeline_ids_;
	std::optional<Clip> clip_;
	bool showing_clip_ = false;  // the rig shows the clip (seek_clip); live generation waits

	uint64_t windows_seen_ = 0;
	uint64_t last_window_id_ = 0;
	std::deque<ShownWindow> window_prompts_;
	uint64_t shown_window_id_ = 0;
	std::optional<std::string> shown_prompt_;
	std::deque<double> latencies_ms_;
	double last_latency_ms_ = 0.0;
	// Main-thread microseconds of the recent frames (_process and the pose write).
	std::array<double, 64> frame_microseconds_{};
	size_t frame_cost_index_ = 0;
	double current_frame_microseconds_ = 0.0;
	bool load_failed_ = false;  // the last load failed (a configuration warning)
	std::string last_error_;
	std::string last_worker_error_;
};

} // namespace ardy
