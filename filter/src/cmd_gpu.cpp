// Placeholder until the GPU context lands (issue 4).
#include "commands.h"

namespace lensfx::filter {
void register_gpu_command(CLI::App&) {}
}  // namespace lensfx::filter
