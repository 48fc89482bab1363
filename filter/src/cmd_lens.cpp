// Placeholder until the lens commands land (issue 3).
#include "commands.h"

namespace lensfx::filter {
void register_lens_commands(CLI::App&) {}
}  // namespace lensfx::filter
