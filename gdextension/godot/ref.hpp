#pragma once
// Ref<T>: a counted reference to an engine RefCounted object.
#include "engine_classes.hpp"

namespace godot {

template <class T>
class Ref {
public:
	Ref() = default;
	Ref(T *object) { reset(object); }
	Ref(const Ref &other) { reset(other.object_); }
	Ref &operator=(const Ref &other) {
		if (this != &other) {
			reset(other.object_);
		}
		return *this;
	}
	~Ref() { reset(nullptr); }

	// Takes over a reference the engine already counted for us (a ptrcall
	// return value), without adding another.
	static Ref adopt(GDExtensionObjectPtr owner) {
		Ref result;
		result.object_ = object_from_owner<T>(owner);
		return result;
	}

	T *ptr() const { return object_; }
	T *operator->() const { return object_; }
	bool is_valid() const { return object_ != nullptr; }
	bool is_null() const { return object_ == nullptr; }

	void reset(T *object) {
		if (object == object_) {
			return;
		}
		if (object != nullptr) {
			object->reference();
		}
		T *old = object_;
		object_ = object;
		if (old != nullptr && old->unreference()) {
			internal::gde.object_destroy(old->_owner);
		}
	}

private:
	T *object_ = nullptr;
};

} // namespace godot
