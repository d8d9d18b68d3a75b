// Compiled by ctest with and without -ffast-math: sylva/shared/lang.h must refuse the former
// with an #error naming the flags it needs (tests/unit/CMakeLists.txt, unit.lang_*).
#include <sylva/shared/lang.h>
int main() { return 0; }
