#include "interface.hpp"

namespace godot::internal {

Interface gde;

const char *load_interface(GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library) {
	gde.library = library;
	gde.token = library;
#define ARDY_GDE_LOAD(member, type, name)                                                  \
	gde.member = reinterpret_cast<GDExtensionInterface##type>(get_proc_address(name)); \
	if (gde.member == nullptr) {                                                        \
		return name;                                                                    \
	}
	ARDY_GDE_FUNCTIONS(ARDY_GDE_LOAD)
#undef ARDY_GDE_LOAD
#define ARDY_GDE_LOAD_OPTIONAL(member, type, name) \
	gde.member = reinterpret_cast<GDExtensionInterface##type>(get_proc_address(name));
	ARDY_GDE_OPTIONAL_FUNCTIONS(ARDY_GDE_LOAD_OPTIONAL)
#undef ARDY_GDE_LOAD_OPTIONAL
	return nullptr;
}

} // namespace godot::internal
