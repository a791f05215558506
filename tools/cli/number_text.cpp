#include "number_text.hpp"

#include <cstdio>

namespace pointfair::cli {

std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace pointfair::cli
