#pragma once
// Wrappers for the engine classes our nodes call. Bind only what is used.
#include "object.hpp"

namespace godot {

template <class T>
class Ref;

class RefCounted : public Object {
	GDENGINECLASS(RefCounted, Object)

public:
	bool init_ref();
	bool reference();
	bool unreference();
};

class Resource : public RefCounted {
	GDENGINECLASS(Resource, RefCounted)

public:
	void emit_changed();
};

// Keyframed tracks (what bake_animation makes).
class Animation : public Resource {
	GDENGINECLASS(Animation, Resource)

public:
	enum TrackType {
		TYPE_POSITION_3D = 1,
		TYPE_ROTATION_3D = 2,
	};
	enum LoopMode {
		LOOP_NONE = 0,
		LOOP_LINEAR = 1,
	};
	int32_t add_track(TrackType type, int32_t at_position = -1);
	void track_set_path(int32_t track, const NodePath &path);
	int32_t rotation_track_insert_key(int32_t track, double time, const Quaternion &rotation);
	int32_t position_track_insert_key(int32_t track, double time, const Vector3 &position);
	void set_length(double seconds);
	void set_step(double seconds);
	void set_loop_mode(LoopMode mode);
};

class Node : public Object {
	GDENGINECLASS(Node, Object)

public:
	enum {
		NOTIFICATION_ENTER_TREE = 10,
		NOTIFICATION_EXIT_TREE = 11,
		NOTIFICATION_READY = 13,
	};

	enum InternalMode {
		INTERNAL_MODE_DISABLED = 0,
		INTERNAL_MODE_FRONT = 1,
		INTERNAL_MODE_BACK = 2,
	};

	Node *get_node_or_null(const NodePath &path) const;
	bool is_inside_tree() const;
	void update_configuration_warnings();
	void set_process(bool enabled);
	void set_physics_process(bool enabled);
	void add_child(Node *child, bool force_readable_name = false, InternalMode internal = INTERNAL_MODE_DISABLED);
	void remove_child(Node *child);
	Node *get_parent() const;
	void queue_free();
	NodePath get_path_to(const Node *node, bool use_unique_path = false) const;

	// Virtual overrides: a class that declares one of these is registered for
	// it (see Node::register_virtuals).
	void _ready() {}
	void _process(double) {}
	void _physics_process(double) {}
	void _enter_tree() {}
	void _exit_tree() {}
	PackedStringArray _get_configuration_warnings() const { return {}; }

	template <class T>
	static void register_virtuals();
};

class Node3D : public Node {
	GDENGINECLASS(Node3D, Node)

public:
	Transform3D get_global_transform() const;
	void set_global_transform(const Transform3D &transform);
	void update_gizmos();
};

class Skeleton3D : public Node3D {
	GDENGINECLASS(Skeleton3D, Node3D)

public:
	int32_t find_bone(const String &name) const;
	int32_t get_bone_count() const;
	String get_bone_name(int32_t bone) const;
	void set_bone_pose_rotation(int32_t bone, const Quaternion &rotation);
	void set_bone_pose_position(int32_t bone, const Vector3 &position);
	Quaternion get_bone_pose_rotation(int32_t bone) const;
	Transform3D get_bone_rest(int32_t bone) const;
	int32_t get_bone_parent(int32_t bone) const;
	Vector3 get_bone_pose_position(int32_t bone) const;
	void set_bone_pose_scale(int32_t bone, const Vector3 &scale);
	// Changes whenever bones are added, removed or re-parented.
	uint64_t get_version() const;
};

// Godot 4.3+ runtime pose writers: they run in the skeleton's update, after
// AnimationMixer, blended by `influence`.
class SkeletonModifier3D : public Node3D {
	GDENGINECLASS(SkeletonModifier3D, Node3D)

public:
	Skeleton3D *get_skeleton() const;
	void set_influence(double influence);
	double get_influence() const;

	void _process_modification_with_delta(double) {}

	template <class T>
	static void register_virtuals();
};

class CharacterBody3D : public Node3D {
	GDENGINECLASS(CharacterBody3D, Node3D)

public:
	void set_velocity(const Vector3 &velocity);
	Vector3 get_velocity() const;
	bool move_and_slide();
	bool is_on_floor() const;
	// PhysicsBody3D.get_gravity: the gravity acting on the body (areas included).
	Vector3 get_gravity() const;
};

class Curve3D : public Resource {
	GDENGINECLASS(Curve3D, Resource)

public:
	PackedVector3Array get_baked_points() const;
};

class Path3D : public Node3D {
	GDENGINECLASS(Path3D, Node3D)

public:
	Ref<Curve3D> get_curve() const;
};

class BoneMap : public Resource {
	GDENGINECLASS(BoneMap, Resource)

public:
	StringName get_skeleton_bone_name(const StringName &profile_bone) const;
};

class FileAccess : public RefCounted {
	GDENGINECLASS(FileAccess, RefCounted)

public:
	enum ModeFlags {
		READ = 1,
		WRITE = 2,
	};
	static Ref<FileAccess> open(const String &path, ModeFlags mode);
	static Error get_open_error();
	uint64_t get_length() const;
	PackedByteArray get_buffer(int64_t length) const;
	Error get_error() const;
	bool store_string(const String &text);
};

// The Engine singleton.
class Engine : public Object {
	GDENGINECLASS(Engine, Object)

public:
	static Engine *get_singleton();
	bool is_editor_hint() const;
};

namespace internal {
// Frees our wrappers of engine singletons (they outlive the extension). Called
// when the extension is unloaded.
void release_singleton_wrappers();
} // namespace internal

// The live object with this instance id, or nullptr once it is freed.
Object *object_from_instance_id(uint64_t id);

// Godot's error_string(): "File not found", ...
String error_string(Error error);

} // namespace godot
