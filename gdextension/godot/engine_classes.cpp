#include "engine_classes.hpp"

#include "engine_call.hpp"
#include "memory.hpp"
#include "ref.hpp"

#include <vector>

namespace godot {

using internal::call_engine;
using internal::gde;

namespace internal {

namespace {
thread_local GDExtensionObjectPtr constructing_owner = nullptr;

template <class T>
Wrapped *make_wrapper(GDExtensionObjectPtr owner) {
	set_constructing_owner(owner);
	return memnew_tracked<T>();
}

// Most derived first, so an object gets the most specific wrapper we have.
// Every engine wrapper class must be listed here.
Wrapped *make_engine_wrapper(GDExtensionObjectPtr owner) {
	using Maker = Wrapped *(*)(GDExtensionObjectPtr);
	struct Rung {
		void *(*tag)();
		Maker make;
	};
	static const Rung ladder[] = {
		{ &Skeleton3D::get_class_tag, &make_wrapper<Skeleton3D> },
		{ &Node3D::get_class_tag, &make_wrapper<Node3D> },
		{ &Node::get_class_tag, &make_wrapper<Node> },
		{ &FileAccess::get_class_tag, &make_wrapper<FileAccess> },
		{ &RefCounted::get_class_tag, &make_wrapper<RefCounted> },
		{ &Engine::get_class_tag, &make_wrapper<Engine> },
	};
	for (const Rung &rung : ladder) {
		if (gde.object_cast_to(owner, rung.tag()) != nullptr) {
			return rung.make(owner);
		}
	}
	return make_wrapper<Object>(owner);
}

void *create_binding(void *, void *instance) {
	return make_engine_wrapper(static_cast<GDExtensionObjectPtr>(instance));
}

void free_binding(void *, void *, void *binding) {
	memdelete(static_cast<Wrapped *>(binding));
}

GDExtensionBool reference_binding(void *, void *, GDExtensionBool) {
	return true;
}

const GDExtensionInstanceBindingCallbacks engine_wrapper_callbacks = { &create_binding, &free_binding, &reference_binding };
} // namespace

GDExtensionObjectPtr take_constructing_owner() {
	GDExtensionObjectPtr owner = constructing_owner;
	constructing_owner = nullptr;
	return owner;
}

void set_constructing_owner(GDExtensionObjectPtr owner) {
	constructing_owner = owner;
}

void *class_tag(const char *class_name) {
	StringName name(class_name);
	return gde.classdb_get_class_tag(name.native_ptr());
}

Wrapped *wrapper_of(GDExtensionObjectPtr object) {
	return static_cast<Wrapped *>(gde.object_get_instance_binding(object, gde.token, &engine_wrapper_callbacks));
}

GDExtensionMethodBindPtr method_bind(const char *class_name, const char *method, int64_t hash) {
	StringName class_string(class_name);
	StringName method_string(method);
	GDExtensionMethodBindPtr bind = gde.classdb_get_method_bind(class_string.native_ptr(), method_string.native_ptr(), hash);
	if (bind == nullptr) {
		const std::string message = std::string("engine method ") + class_name + "." + method + " not found (hash " + std::to_string(hash) + "): the engine's API differs from the one this extension was built against";
		gde.print_error(message.c_str(), __func__, __FILE__, __LINE__, false);
	}
	return bind;
}

} // namespace internal

String Object::get_class() const {
	return call_engine<String>(ARDY_ENGINE_METHOD(Object, get_class), _owner);
}

bool Object::is_class(const String &name) const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Object, is_class), _owner, name);
}

uint64_t Object::get_instance_id() const {
	return call_engine<uint64_t>(ARDY_ENGINE_METHOD(Object, get_instance_id), _owner);
}

void Object::emit_signal_variants(const Variant *values, int count) {
	std::vector<GDExtensionConstVariantPtr> pointers(static_cast<std::size_t>(count));
	for (int i = 0; i < count; ++i) {
		pointers[static_cast<std::size_t>(i)] = values[i].native_ptr();
	}
	Variant result;
	GDExtensionCallError error{};
	gde.variant_destroy(result.native_ptr());
	gde.object_method_bind_call(ARDY_ENGINE_METHOD(Object, emit_signal), _owner, pointers.data(), count, result.native_ptr(), &error);
}

bool RefCounted::init_ref() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, init_ref), _owner);
}

bool RefCounted::reference() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, reference), _owner);
}

bool RefCounted::unreference() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, unreference), _owner);
}

Node *Node::get_node_or_null(const NodePath &path) const {
	return call_engine<Node *>(ARDY_ENGINE_METHOD(Node, get_node_or_null), _owner, path);
}

bool Node::is_inside_tree() const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Node, is_inside_tree), _owner);
}

void Node::update_configuration_warnings() {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, update_configuration_warnings), _owner);
}

void Node::set_process(bool enabled) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, set_process), _owner, enabled);
}

int32_t Skeleton3D::find_bone(const String &name) const {
	return call_engine<int32_t>(ARDY_ENGINE_METHOD(Skeleton3D, find_bone), _owner, name);
}

int32_t Skeleton3D::get_bone_count() const {
	return call_engine<int32_t>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_count), _owner);
}

String Skeleton3D::get_bone_name(int32_t bone) const {
	return call_engine<String>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_name), _owner, bone);
}

void Skeleton3D::set_bone_pose_rotation(int32_t bone, const Quaternion &rotation) {
	call_engine<void>(ARDY_ENGINE_METHOD(Skeleton3D, set_bone_pose_rotation), _owner, bone, rotation);
}

void Skeleton3D::set_bone_pose_position(int32_t bone, const Vector3 &position) {
	call_engine<void>(ARDY_ENGINE_METHOD(Skeleton3D, set_bone_pose_position), _owner, bone, position);
}

Quaternion Skeleton3D::get_bone_pose_rotation(int32_t bone) const {
	return call_engine<Quaternion>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_pose_rotation), _owner, bone);
}

Transform3D Skeleton3D::get_bone_rest(int32_t bone) const {
	return call_engine<Transform3D>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_rest), _owner, bone);
}

Ref<FileAccess> FileAccess::open(const String &path, ModeFlags mode) {
	return call_engine<Ref<FileAccess>>(ARDY_ENGINE_METHOD(FileAccess, open), nullptr, path, static_cast<int64_t>(mode));
}

Error FileAccess::get_open_error() {
	return static_cast<Error>(call_engine<int64_t>(ARDY_ENGINE_METHOD(FileAccess, get_open_error), nullptr));
}

uint64_t FileAccess::get_length() const {
	return call_engine<uint64_t>(ARDY_ENGINE_METHOD(FileAccess, get_length), _owner);
}

PackedByteArray FileAccess::get_buffer(int64_t length) const {
	return call_engine<PackedByteArray>(ARDY_ENGINE_METHOD(FileAccess, get_buffer), _owner, length);
}

Error FileAccess::get_error() const {
	return static_cast<Error>(call_engine<int64_t>(ARDY_ENGINE_METHOD(FileAccess, get_error), _owner));
}

Engine *Engine::get_singleton() {
	static Engine *singleton = [] {
		StringName name("Engine");
		return object_from_owner<Engine>(gde.global_get_singleton(name.native_ptr()));
	}();
	return singleton;
}

bool Engine::is_editor_hint() const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Engine, is_editor_hint), _owner);
}

String error_string(Error error) {
	static const GDExtensionPtrUtilityFunction function = [] {
		StringName name("error_string");
		return gde.variant_get_ptr_utility_function(name.native_ptr(), engine_api::hash_utility_error_string);
	}();
	const int64_t code = error;
	const GDExtensionConstTypePtr args[1] = { &code };
	String result;
	function(result.native_ptr(), args, 1);
	return result;
}

} // namespace godot
