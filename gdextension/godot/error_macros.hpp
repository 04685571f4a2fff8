#pragma once
// Engine error output, with the C++ location, as godot-cpp's macros give it.
#include "interface.hpp"

#include <string>

namespace godot::internal {
inline void print_error(const std::string &message, const char *function, const char *file, int line) {
	gde.print_error(message.c_str(), function, file, line, true);
}
inline void print_warning(const std::string &message, const char *function, const char *file, int line) {
	gde.print_warning(message.c_str(), function, file, line, true);
}
} // namespace godot::internal

#define ERR_PRINT(m_message) ::godot::internal::print_error(m_message, __func__, __FILE__, __LINE__)
#define WARN_PRINT(m_message) ::godot::internal::print_warning(m_message, __func__, __FILE__, __LINE__)
