// Placeholder until the frame pipeline lands (issue 2): the filter options are not registered yet.
#include "commands.h"

namespace lensfx::filter {
void register_filter(CLI::App&) {}
}  // namespace lensfx::filter
