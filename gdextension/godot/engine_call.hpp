#pragma once
// Calls into engine methods through method binds (ptrcall), with the hashes
// generated from the engine's API dump.
#include "ptr_to_arg.hpp"

#include <tuple>

namespace godot::internal {

GDExtensionMethodBindPtr method_bind(const char *class_name, const char *method, int64_t hash);

// A method bind resolved once, on first use.
#define ARDY_ENGINE_METHOD(m_class, m_method)                                                        \
	([]() {                                                                                          \
		static const GDExtensionMethodBindPtr bind =                                                 \
				::godot::internal::method_bind(#m_class, #m_method, ::godot::engine_api::hash_##m_class##_##m_method); \
		return bind;                                                                                 \
	}())

template <class R, class... Args>
R call_engine(GDExtensionMethodBindPtr bind, GDExtensionObjectPtr object, const Args &...args) {
	std::tuple<typename PtrToArg<Bare<Args>>::Encoded...> encoded(PtrToArg<Bare<Args>>::encode(args)...);
	const GDExtensionConstTypePtr pointers[sizeof...(Args) + 1] = {};
	std::apply([&](auto &...values) {
		GDExtensionConstTypePtr *out = const_cast<GDExtensionConstTypePtr *>(pointers);
		((*out++ = &values), ...);
	},
			encoded);
	if constexpr (std::is_void_v<R>) {
		gde.object_method_bind_ptrcall(bind, object, pointers, nullptr);
	} else {
		typename PtrToArg<R>::Encoded result{};
		gde.object_method_bind_ptrcall(bind, object, pointers, &result);
		return PtrToArg<R>::decode_return(result);
	}
}

} // namespace godot::internal
