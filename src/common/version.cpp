#include "pointfair/common/version.hpp"

namespace pointfair {
const char* version() { return POINTFAIR_VERSION; }
}  // namespace pointfair
