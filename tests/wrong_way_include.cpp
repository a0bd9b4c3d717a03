// Compiled only by module_arrows_test, which expects it to fail: detection may not see the
// pipeline's headers (DESIGN.md's arrows, enforced by cmake/fdv_module.cmake's include roots).
#include "fdv/pipeline/perception.h"
