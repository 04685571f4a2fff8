#pragma once
// Engine-tracked allocation, as in godot-cpp: objects made with memnew count in
// the engine's static memory monitor, so leaks show up in engine tests.
#include "interface.hpp"

#include <new>
#include <utility>

namespace godot {

template <class T, class... Args>
T *memnew_tracked(Args &&...args) {
	void *memory = internal::gde.mem_alloc(sizeof(T));
	if (memory == nullptr) {
		throw std::bad_alloc();
	}
	return ::new (memory) T(std::forward<Args>(args)...);
}

template <class T>
void memdelete(T *object) {
	if (object != nullptr) {
		object->~T();
		internal::gde.mem_free(object);
	}
}

} // namespace godot
