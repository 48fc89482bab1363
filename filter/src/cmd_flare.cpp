// Placeholder until the flare renderer lands (issue 4).
#include "commands.h"

namespace lensfx::filter {
void register_flare_command(CLI::App&) {}
}  // namespace lensfx::filter
