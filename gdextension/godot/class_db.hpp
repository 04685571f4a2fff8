#pragma once
// One-line registration of classes, methods (with default arguments),
// properties (with hints, usage and groups), signals and virtual overrides,
// in the shape godot-cpp gives them.
#include "engine_classes.hpp"
#include "memory.hpp"
#include "ptr_to_arg.hpp"

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace godot {

struct PropertyInfo {
	Variant::Type type = Variant::NIL;
	std::string name;
	PropertyHint hint = PROPERTY_HINT_NONE;
	std::string hint_string;
	uint32_t usage = PROPERTY_USAGE_DEFAULT;
	std::string class_name;

	PropertyInfo() = default;
	PropertyInfo(Variant::Type type, std::string name, PropertyHint hint = PROPERTY_HINT_NONE, std::string hint_string = "",
			uint32_t usage = PROPERTY_USAGE_DEFAULT, std::string class_name = "") :
			type(type), name(std::move(name)), hint(hint), hint_string(std::move(hint_string)), usage(usage), class_name(std::move(class_name)) {}
};

struct MethodInfo {
	std::string name;
	std::vector<PropertyInfo> arguments;

	template <class... Args>
	explicit MethodInfo(std::string name, Args... arguments) : name(std::move(name)), arguments{ std::move(arguments)... } {}
};

struct MethodDefinition {
	std::string name;
	std::vector<std::string> arguments;
};

template <class... Args>
MethodDefinition D_METHOD(const char *name, Args... arguments) {
	return MethodDefinition{ name, { arguments... } };
}

#define DEFVAL(m_value) ::godot::Variant(m_value)

namespace internal {

// A registered method: untyped (Variant) calls and typed (ptr) calls.
class MethodBind {
public:
	virtual ~MethodBind() = default;
	virtual void call(GDExtensionClassInstancePtr instance, const GDExtensionConstVariantPtr *args, GDExtensionInt count,
			GDExtensionVariantPtr r_return, GDExtensionCallError *r_error) const = 0;
	virtual void ptrcall(GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret) const = 0;

	MethodDefinition definition;
	std::vector<Variant> defaults;
	bool has_return = false;
	PropertyInfo return_info;
	GDExtensionClassMethodArgumentMetadata return_metadata = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
	std::vector<PropertyInfo> argument_info;
	std::vector<GDExtensionClassMethodArgumentMetadata> argument_metadata;
	uint32_t flags = GDEXTENSION_METHOD_FLAGS_DEFAULT;
};

template <class A>
PropertyInfo property_info_of(const std::string &name) {
	// A Variant is typed NIL; the flag tells the engine it is any value, not void.
	const uint32_t usage = TypeInfo<A>::type == Variant::NIL ? PROPERTY_USAGE_DEFAULT | PROPERTY_USAGE_NIL_IS_VARIANT : PROPERTY_USAGE_DEFAULT;
	return PropertyInfo(TypeInfo<A>::type, name, PROPERTY_HINT_NONE, "", usage, TypeInfo<A>::class_name());
}

// Checks and converts one Variant argument as the engine would; on failure
// fills r_error the way GDScript reports a bad argument.
bool convert_argument(const Variant &value, Variant::Type expected, void *class_tag, int index, Variant &r_converted,
		GDExtensionCallError *r_error);

template <class A>
void *class_tag_of() {
	if constexpr (TypeInfo<A>::type == Variant::OBJECT) {
		using Pointee = std::remove_pointer_t<A>;
		if constexpr (std::is_pointer_v<A>) {
			return Pointee::get_class_tag();
		} else {
			return nullptr;
		}
	} else {
		return nullptr;
	}
}

template <class T, class R, bool IsConst, class... A>
class MethodBindT final : public MethodBind {
public:
	using Method = std::conditional_t<IsConst, R (T::*)(A...) const, R (T::*)(A...)>;
	explicit MethodBindT(Method method) : method_(method) {}

	void call(GDExtensionClassInstancePtr instance, const GDExtensionConstVariantPtr *args, GDExtensionInt count,
			GDExtensionVariantPtr r_return, GDExtensionCallError *r_error) const override {
		constexpr int arity = sizeof...(A);
		const int first_default = arity - static_cast<int>(defaults.size());
		if (count > arity) {
			*r_error = { GDEXTENSION_CALL_ERROR_TOO_MANY_ARGUMENTS, 0, arity };
			return;
		}
		if (count < first_default) {
			*r_error = { GDEXTENSION_CALL_ERROR_TOO_FEW_ARGUMENTS, 0, first_default };
			return;
		}
		Variant converted[arity > 0 ? arity : 1];
		for (int i = 0; i < arity; ++i) {
			const Variant &value = i < count ? *static_cast<const Variant *>(args[i]) : defaults[static_cast<std::size_t>(i - first_default)];
			if (!convert_argument(value, expected_types_[i], expected_tags()[i], i, converted[i], r_error)) {
				return;
			}
		}
		invoke_variant(instance, converted, r_return, std::index_sequence_for<A...>{});
		r_error->error = GDEXTENSION_CALL_OK;
	}

	void ptrcall(GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret) const override {
		invoke_ptr(instance, args, r_ret, std::index_sequence_for<A...>{});
	}

private:
	static T *self(GDExtensionClassInstancePtr instance) { return static_cast<T *>(static_cast<Wrapped *>(instance)); }

	static const std::vector<void *> &expected_tags() {
		static const std::vector<void *> tags{ class_tag_of<Bare<A>>()... };
		return tags;
	}

	template <std::size_t... I>
	void invoke_variant(GDExtensionClassInstancePtr instance, Variant *converted, GDExtensionVariantPtr r_return, std::index_sequence<I...>) const {
		(void)converted;
		if constexpr (std::is_void_v<R>) {
			(self(instance)->*method_)(VariantCaster<Bare<A>>::from(converted[I])...);
		} else {
			Variant result = VariantCaster<Bare<R>>::to((self(instance)->*method_)(VariantCaster<Bare<A>>::from(converted[I])...));
			// r_return holds a nil Variant: overwrite it with a copy.
			gde.variant_new_copy(r_return, result.native_ptr());
		}
	}

	template <std::size_t... I>
	void invoke_ptr(GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret, std::index_sequence<I...>) const {
		(void)args;
		if constexpr (std::is_void_v<R>) {
			(self(instance)->*method_)(PtrToArg<Bare<A>>::decode(*static_cast<const typename PtrToArg<Bare<A>>::Encoded *>(args[I]))...);
		} else {
			write_ptr_return<Bare<R>>((self(instance)->*method_)(PtrToArg<Bare<A>>::decode(*static_cast<const typename PtrToArg<Bare<A>>::Encoded *>(args[I]))...), r_ret);
		}
	}

	Method method_;
	static constexpr Variant::Type expected_types_[sizeof...(A) + 1] = { TypeInfo<Bare<A>>::type..., Variant::NIL };
};

using VirtualCall = void (*)(GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret);

struct ClassRecord {
	StringName name;
	StringName parent;
	StringName engine_base;
	std::map<std::string, VirtualCall> virtuals;
	std::vector<std::unique_ptr<MethodBind>> methods;
};

template <class T>
constexpr const char *engine_base_name() {
	if constexpr (T::is_extension_class) {
		return engine_base_name<typename T::parent_type>();
	} else {
		return T::get_class_static();
	}
}

GDExtensionObjectPtr construct_engine_object(const StringName &class_name);
void attach_extension_instance(GDExtensionObjectPtr owner, const StringName &class_name, Wrapped *instance);

} // namespace internal

class ClassDB {
public:
	template <class T>
	static void register_class() {
		internal::ClassRecord &record = begin_class(T::get_class_static(), T::parent_type::get_class_static(), internal::engine_base_name<T>());
		GDExtensionClassCreationInfo5 info{};
		info.is_exposed = true;
		info.create_instance_func = &create_instance<T>;
		info.free_instance_func = &free_instance<T>;
		if constexpr (!std::is_same_v<decltype(&T::_notification), decltype(&Wrapped::_notification)>) {
			info.notification_func = &notify<T>;
		}
		info.get_virtual_call_data_func = &virtual_call_data;
		info.call_virtual_with_data_func = &call_virtual;
		info.class_userdata = &record;
		finish_registration(record, info);
		T::_bind_methods();
		T::template register_virtuals<T>();
		current_class_ = nullptr;
	}

	template <class T, class R, class... A, class... D>
	static void bind_method(const MethodDefinition &definition, R (T::*method)(A...), D... defaults) {
		add_method(std::make_unique<internal::MethodBindT<T, R, false, A...>>(method), definition, { Variant(defaults)... });
	}
	template <class T, class R, class... A, class... D>
	static void bind_method(const MethodDefinition &definition, R (T::*method)(A...) const, D... defaults) {
		auto bind = std::make_unique<internal::MethodBindT<T, R, true, A...>>(method);
		bind->flags |= GDEXTENSION_METHOD_FLAG_CONST;
		add_method(std::move(bind), definition, { Variant(defaults)... });
	}

	static void add_property(const PropertyInfo &info, const char *setter, const char *getter);
	static void add_property_group(const char *name, const char *prefix);
	static void add_signal(const MethodInfo &signal);
	static void bind_virtual(const char *name, internal::VirtualCall call);

	static void load_editor_help(const char *xml, std::size_t size);
	// Unregisters every class, newest first, and frees the registry.
	static void unregister_all();

private:
	template <class T>
	static GDExtensionObjectPtr create_instance(void *class_userdata, GDExtensionBool) {
		auto *record = static_cast<internal::ClassRecord *>(class_userdata);
		GDExtensionObjectPtr owner = internal::construct_engine_object(record->engine_base);
		internal::set_constructing_owner(owner);
		T *instance = memnew_tracked<T>();
		internal::attach_extension_instance(owner, record->name, instance);
		return owner;
	}

	template <class T>
	static void free_instance(void *, GDExtensionClassInstancePtr instance) {
		memdelete(static_cast<T *>(static_cast<Wrapped *>(instance)));
	}

	template <class T>
	static void notify(GDExtensionClassInstancePtr instance, int32_t what, GDExtensionBool) {
		static_cast<T *>(static_cast<Wrapped *>(instance))->_notification(what);
	}

	template <class M>
	static void add_method(std::unique_ptr<M> bind, const MethodDefinition &definition, std::vector<Variant> defaults) {
		fill_signature(*bind, static_cast<typename M::Method>(nullptr));
		add_method_bind(std::move(bind), definition, std::move(defaults));
	}

	template <class M, class T, class R, class... A>
	static void fill_signature(M &bind, R (T::*)(A...)) {
		fill_types<R, A...>(bind);
	}
	template <class M, class T, class R, class... A>
	static void fill_signature(M &bind, R (T::*)(A...) const) {
		fill_types<R, A...>(bind);
	}
	template <class R, class... A>
	static void fill_types(internal::MethodBind &bind) {
		if constexpr (!std::is_void_v<R>) {
			bind.has_return = true;
			bind.return_info = internal::property_info_of<Bare<R>>("");
			bind.return_metadata = TypeInfo<Bare<R>>::metadata;
		}
		bind.argument_info = { internal::property_info_of<Bare<A>>("")... };
		bind.argument_metadata = { TypeInfo<Bare<A>>::metadata... };
	}

	static internal::ClassRecord &begin_class(const char *name, const char *parent, const char *engine_base);
	static void finish_registration(internal::ClassRecord &record, const GDExtensionClassCreationInfo5 &info);
	static void add_method_bind(std::unique_ptr<internal::MethodBind> bind, const MethodDefinition &definition, std::vector<Variant> defaults);
	static void *virtual_call_data(void *class_userdata, GDExtensionConstStringNamePtr name, uint32_t hash);
	static void call_virtual(GDExtensionClassInstancePtr instance, GDExtensionConstStringNamePtr name, void *userdata,
			const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret);

	static internal::ClassRecord *current_class_;
};

// A new engine object of class T (an engine class or one of ours), owned by
// the caller as the engine's objects are: free it with queue_free() or add it
// to the tree.
template <class T>
T *memnew_object() {
	return object_from_owner<T>(internal::construct_engine_object(StringName(T::get_class_static())));
}

#define ADD_PROPERTY(m_info, m_setter, m_getter) ::godot::ClassDB::add_property(m_info, m_setter, m_getter)
#define ADD_GROUP(m_name, m_prefix) ::godot::ClassDB::add_property_group(m_name, m_prefix)
#define ADD_SIGNAL(m_info) ::godot::ClassDB::add_signal(m_info)

// Registers the Node virtuals that T declares itself.
template <class T>
void Node::register_virtuals() {
	if constexpr (!std::is_same_v<decltype(&T::_ready), decltype(&Node::_ready)>) {
		ClassDB::bind_virtual("_ready", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_ready();
		});
	}
	if constexpr (!std::is_same_v<decltype(&T::_enter_tree), decltype(&Node::_enter_tree)>) {
		ClassDB::bind_virtual("_enter_tree", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_enter_tree();
		});
	}
	if constexpr (!std::is_same_v<decltype(&T::_exit_tree), decltype(&Node::_exit_tree)>) {
		ClassDB::bind_virtual("_exit_tree", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_exit_tree();
		});
	}
	if constexpr (!std::is_same_v<decltype(&T::_process), decltype(&Node::_process)>) {
		ClassDB::bind_virtual("_process", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *args, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_process(*static_cast<const double *>(args[0]));
		});
	}
	if constexpr (!std::is_same_v<decltype(&T::_physics_process), decltype(&Node::_physics_process)>) {
		ClassDB::bind_virtual("_physics_process", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *args, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_physics_process(*static_cast<const double *>(args[0]));
		});
	}
	if constexpr (!std::is_same_v<decltype(&T::_get_configuration_warnings), decltype(&Node::_get_configuration_warnings)>) {
		ClassDB::bind_virtual("_get_configuration_warnings", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *, GDExtensionTypePtr r_ret) {
			write_ptr_return(static_cast<const T *>(static_cast<Wrapped *>(p))->_get_configuration_warnings(), r_ret);
		});
	}
}

// Registers the SkeletonModifier3D virtuals that T declares itself (and Node's).
template <class T>
void SkeletonModifier3D::register_virtuals() {
	Node::register_virtuals<T>();
	if constexpr (!std::is_same_v<decltype(&T::_process_modification_with_delta), decltype(&SkeletonModifier3D::_process_modification_with_delta)>) {
		ClassDB::bind_virtual("_process_modification_with_delta", [](GDExtensionClassInstancePtr p, const GDExtensionConstTypePtr *args, GDExtensionTypePtr) {
			static_cast<T *>(static_cast<Wrapped *>(p))->_process_modification_with_delta(*static_cast<const double *>(args[0]));
		});
	}
}

} // namespace godot
