// The one liveness check of the processes that left temporaries behind (optics/process_liveness.h), used by
// the outputs' and the caches' clean-up.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <optics/process_liveness.h>

namespace lensfx {
namespace {

TEST(ProcessLiveness, OnlyAProcessThatNoLongerExistsIsGone) {
    EXPECT_FALSE(process_is_gone(::getpid()));
    EXPECT_FALSE(process_is_gone(1)) << "init runs (and may not be signalled: EPERM is not gone)";
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) ::_exit(0);
    EXPECT_FALSE(process_is_gone(child)) << "a child not yet reaped still exists";
    ASSERT_EQ(::waitpid(child, nullptr, 0), child);
    EXPECT_TRUE(process_is_gone(child));
    EXPECT_TRUE(process_is_gone(2147483646)) << "above any pid_max";
}

}  // namespace
}  // namespace lensfx
