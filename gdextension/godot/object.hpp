#pragma once
// Object handles. Every engine object we touch gets one C++ wrapper, kept as
// the object's instance binding and freed by the engine with the object, so a
// pointer such as `Skeleton3D *` is stable and reads like godot-cpp code.
#include "variant.hpp"

namespace godot {

class ClassDB;
class Wrapped;

namespace internal {
// Set while a wrapper is being constructed, so its constructor can see the
// engine object it wraps (the same trick godot-cpp uses).
GDExtensionObjectPtr take_constructing_owner();
void set_constructing_owner(GDExtensionObjectPtr owner);
void *class_tag(const char *class_name);
// The wrapper bound to `object`, creating the most derived engine wrapper we
// have when there is none yet.
Wrapped *wrapper_of(GDExtensionObjectPtr object);
} // namespace internal

class Wrapped {
public:
	Wrapped() : _owner(internal::take_constructing_owner()) {}
	Wrapped(const Wrapped &) = delete;
	Wrapped &operator=(const Wrapped &) = delete;
	virtual ~Wrapped() = default;

	GDExtensionObjectPtr _owner = nullptr;

	static const char *get_class_static() { return "Wrapped"; }
	// Overridable hooks, found by name by ClassDB::register_class.
	static void _bind_methods() {}
	template <class T>
	static void register_virtuals() {}
	void _notification(int) {}
};

// Shared by engine wrappers and extension classes.
#define ARDY_CLASS_COMMON(m_class, m_inherits)          \
public:                                                 \
	using self_type = m_class;                          \
	using parent_type = m_inherits;                     \
	static const char *get_class_static() { return #m_class; } \
	static void *get_class_tag() {                      \
		static void *tag = ::godot::internal::class_tag(#m_class); \
		return tag;                                     \
	}                                                   \
                                                        \
private:

// An engine class we call into (no registration).
#define GDENGINECLASS(m_class, m_inherits) \
	ARDY_CLASS_COMMON(m_class, m_inherits) \
public:                                    \
	static constexpr bool is_extension_class = false; \
                                           \
private:

// A class this extension registers with the engine.
#define GDCLASS(m_class, m_inherits)       \
	ARDY_CLASS_COMMON(m_class, m_inherits) \
	friend class ::godot::ClassDB;         \
                                           \
public:                                    \
	static constexpr bool is_extension_class = true; \
                                           \
private:

class Object : public Wrapped {
	GDENGINECLASS(Object, Wrapped)

public:
	String get_class() const;
	bool is_class(const String &name) const;
	uint64_t get_instance_id() const;

	// Emits a signal with any number of Variant-convertible arguments.
	template <class... Args>
	void emit_signal(const StringName &signal, const Args &...args) {
		const Variant values[] = { Variant(signal), Variant(args)... };
		emit_signal_variants(values, sizeof...(Args) + 1);
	}

	template <class T>
	static T *cast_to(Object *object) {
		if (object == nullptr || internal::gde.object_cast_to(object->_owner, T::get_class_tag()) == nullptr) {
			return nullptr;
		}
		return static_cast<T *>(object);
	}
	template <class T>
	static const T *cast_to(const Object *object) {
		return cast_to<T>(const_cast<Object *>(object));
	}

private:
	void emit_signal_variants(const Variant *values, int count);
};

// The wrapper of an engine object viewed as T, or nullptr when it is not a T.
template <class T>
T *object_from_owner(GDExtensionObjectPtr owner) {
	if (owner == nullptr) {
		return nullptr;
	}
	return Object::cast_to<T>(static_cast<Object *>(internal::wrapper_of(owner)));
}

} // namespace godot
