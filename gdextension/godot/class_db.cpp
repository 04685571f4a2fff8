#include "class_db.hpp"

namespace godot {

using internal::gde;

internal::ClassRecord *ClassDB::current_class_ = nullptr;

namespace {
// Classes registered so far, in order; freed by unregister_all().
std::unique_ptr<std::vector<std::unique_ptr<internal::ClassRecord>>> registry;

void *create_extension_binding(void *, void *) {
	return nullptr;
}
void free_extension_binding(void *, void *, void *) {
	// The instance is freed by free_instance, with the engine object.
}
GDExtensionBool reference_extension_binding(void *, void *, GDExtensionBool) {
	return true;
}
const GDExtensionInstanceBindingCallbacks extension_binding_callbacks = { &create_extension_binding, &free_extension_binding, &reference_extension_binding };

// Keeps the engine-side values a GDExtensionPropertyInfo points to alive.
struct NativePropertyInfo {
	StringName name;
	StringName class_name;
	String hint_string;
	GDExtensionPropertyInfo info{};

	explicit NativePropertyInfo(const PropertyInfo &source) :
			name(source.name.c_str()), class_name(source.class_name.c_str()), hint_string(source.hint_string.c_str()) {
		info.type = static_cast<GDExtensionVariantType>(source.type);
		info.name = name.native_ptr();
		info.class_name = class_name.native_ptr();
		info.hint = static_cast<uint32_t>(source.hint);
		info.hint_string = hint_string.native_ptr();
		info.usage = source.usage;
	}
	NativePropertyInfo(const NativePropertyInfo &) = delete;
	NativePropertyInfo &operator=(const NativePropertyInfo &) = delete;
};

std::vector<std::unique_ptr<NativePropertyInfo>> native_infos(const std::vector<PropertyInfo> &infos, std::vector<GDExtensionPropertyInfo> &r_raw) {
	std::vector<std::unique_ptr<NativePropertyInfo>> result;
	for (const PropertyInfo &info : infos) {
		result.push_back(std::make_unique<NativePropertyInfo>(info));
		r_raw.push_back(result.back()->info);
	}
	return result;
}

void method_call(void *method_userdata, GDExtensionClassInstancePtr instance, const GDExtensionConstVariantPtr *args, GDExtensionInt count,
		GDExtensionVariantPtr r_return, GDExtensionCallError *r_error) {
	static_cast<const internal::MethodBind *>(method_userdata)->call(instance, args, count, r_return, r_error);
}

void method_ptrcall(void *method_userdata, GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret) {
	static_cast<const internal::MethodBind *>(method_userdata)->ptrcall(instance, args, r_ret);
}
} // namespace

namespace internal {

bool convert_argument(const Variant &value, Variant::Type expected, void *class_tag, int index, Variant &r_converted,
		GDExtensionCallError *r_error) {
	const Variant::Type found = value.get_type();
	if (expected == Variant::NIL || found == expected) {
		r_converted = value;
	} else if (expected == Variant::OBJECT && found == Variant::NIL) {
		r_converted = value;
		return true;
	} else if (!value.convert_to(expected, r_converted)) {
		*r_error = { GDEXTENSION_CALL_ERROR_INVALID_ARGUMENT, index, static_cast<int32_t>(expected) };
		return false;
	}
	if (expected == Variant::OBJECT && class_tag != nullptr && gde.object_cast_to(r_converted.object_ptr(), class_tag) == nullptr) {
		*r_error = { GDEXTENSION_CALL_ERROR_INVALID_ARGUMENT, index, static_cast<int32_t>(expected) };
		return false;
	}
	return true;
}

GDExtensionObjectPtr construct_engine_object(const StringName &class_name) {
	return gde.classdb_construct_object2(class_name.native_ptr());
}

void attach_extension_instance(GDExtensionObjectPtr owner, const StringName &class_name, Wrapped *instance) {
	gde.object_set_instance(owner, class_name.native_ptr(), instance);
	gde.object_set_instance_binding(owner, gde.token, instance, &extension_binding_callbacks);
}

} // namespace internal

internal::ClassRecord &ClassDB::begin_class(const char *name, const char *parent, const char *engine_base) {
	if (registry == nullptr) {
		registry = std::make_unique<std::vector<std::unique_ptr<internal::ClassRecord>>>();
	}
	auto record = std::make_unique<internal::ClassRecord>();
	record->name = StringName(name);
	record->parent = StringName(parent);
	record->engine_base = StringName(engine_base);
	registry->push_back(std::move(record));
	current_class_ = registry->back().get();
	return *current_class_;
}

void ClassDB::finish_registration(internal::ClassRecord &record, const GDExtensionClassCreationInfo5 &info) {
	gde.classdb_register_extension_class5(gde.library, record.name.native_ptr(), record.parent.native_ptr(), &info);
}

void ClassDB::add_method_bind(std::unique_ptr<internal::MethodBind> bind, const MethodDefinition &definition, std::vector<Variant> defaults) {
	internal::MethodBind &method = *bind;
	current_class_->methods.push_back(std::move(bind));
	method.definition = definition;
	method.defaults = std::move(defaults);
	for (std::size_t i = 0; i < method.argument_info.size() && i < definition.arguments.size(); ++i) {
		method.argument_info[i].name = definition.arguments[i];
	}
	if (definition.arguments.size() != method.argument_info.size()) {
		const std::string message = "bind_method " + definition.name + ": " + std::to_string(definition.arguments.size()) + " argument names for " +
				std::to_string(method.argument_info.size()) + " arguments";
		gde.print_error(message.c_str(), __func__, __FILE__, __LINE__, false);
	}

	StringName name(definition.name.c_str());
	std::vector<GDExtensionPropertyInfo> raw_arguments;
	const auto argument_storage = native_infos(method.argument_info, raw_arguments);
	NativePropertyInfo return_info(method.return_info);
	std::vector<GDExtensionVariantPtr> default_pointers;
	for (Variant &value : method.defaults) {
		default_pointers.push_back(value.native_ptr());
	}

	GDExtensionClassMethodInfo info{};
	info.name = name.native_ptr();
	info.method_userdata = &method;
	info.call_func = &method_call;
	info.ptrcall_func = &method_ptrcall;
	info.method_flags = method.flags;
	info.has_return_value = method.has_return;
	info.return_value_info = &return_info.info;
	info.return_value_metadata = method.return_metadata;
	info.argument_count = static_cast<uint32_t>(raw_arguments.size());
	info.arguments_info = raw_arguments.data();
	info.arguments_metadata = method.argument_metadata.data();
	info.default_argument_count = static_cast<uint32_t>(default_pointers.size());
	info.default_arguments = default_pointers.data();
	gde.classdb_register_extension_class_method(gde.library, current_class_->name.native_ptr(), &info);
}

void ClassDB::add_property(const PropertyInfo &info, const char *setter, const char *getter) {
	NativePropertyInfo native(info);
	StringName setter_name(setter);
	StringName getter_name(getter);
	gde.classdb_register_extension_class_property(gde.library, current_class_->name.native_ptr(), &native.info, setter_name.native_ptr(), getter_name.native_ptr());
}

void ClassDB::add_property_group(const char *name, const char *prefix) {
	String group(name);
	String group_prefix(prefix);
	gde.classdb_register_extension_class_property_group(gde.library, current_class_->name.native_ptr(), group.native_ptr(), group_prefix.native_ptr());
}

void ClassDB::add_signal(const MethodInfo &signal) {
	StringName name(signal.name.c_str());
	std::vector<GDExtensionPropertyInfo> raw_arguments;
	const auto storage = native_infos(signal.arguments, raw_arguments);
	gde.classdb_register_extension_class_signal(gde.library, current_class_->name.native_ptr(), name.native_ptr(), raw_arguments.data(),
			static_cast<GDExtensionInt>(raw_arguments.size()));
}

void ClassDB::bind_virtual(const char *name, internal::VirtualCall call) {
	current_class_->virtuals[name] = call;
}

void *ClassDB::virtual_call_data(void *class_userdata, GDExtensionConstStringNamePtr name, uint32_t) {
	auto *record = static_cast<internal::ClassRecord *>(class_userdata);
	const std::string key = String(*static_cast<const StringName *>(name)).utf8();
	auto found = record->virtuals.find(key);
	return found != record->virtuals.end() ? reinterpret_cast<void *>(found->second) : nullptr;
}

void ClassDB::call_virtual(GDExtensionClassInstancePtr instance, GDExtensionConstStringNamePtr, void *userdata,
		const GDExtensionConstTypePtr *args, GDExtensionTypePtr r_ret) {
	reinterpret_cast<internal::VirtualCall>(userdata)(instance, args, r_ret);
}

void ClassDB::load_editor_help(const char *xml, std::size_t size) {
	if (gde.editor_help_load_xml_from_utf8_chars_and_len == nullptr) {
		return;
	}
	gde.editor_help_load_xml_from_utf8_chars_and_len(xml, static_cast<GDExtensionInt>(size));
}

void ClassDB::unregister_all() {
	if (registry == nullptr) {
		return;
	}
	for (auto it = registry->rbegin(); it != registry->rend(); ++it) {
		gde.classdb_unregister_extension_class(gde.library, (*it)->name.native_ptr());
	}
	registry.reset();
}

} // namespace godot
