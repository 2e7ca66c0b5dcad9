#pragma once
// A number in a message, as printf formats it (the messages the workflows put in their results).

#include <cstdio>
#include <string>

namespace sid::detail {

inline std::string format_number(const char* format, double v) {
  char text[64];
  std::snprintf(text, sizeof text, format, v);
  return text;
}

}  // namespace sid::detail
