// Built against the installed package only. Include every public header a user would, and
// check one real result from each, so a header that fails to install (or to compile outside
// the source tree) fails here. Add new headers to the list below.
#include <sylva/core/error.hpp>
#include <sylva/shared/lang.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace {

int failures = 0;

void check(bool ok, const char* what) {
    if (!ok) {
        std::fprintf(stderr, "sylva_consumer: FAILED: %s\n", what);
        ++failures;
    }
}

}  // namespace

int main() {
    // The shared bridge: 1/-0 must be -inf on the host exactly as in the shaders.
    const float r = sylva::shared::sylva_safe_rcp(-0.0f);
    check(std::isinf(r) && std::signbit(r), "sylva_safe_rcp(-0.0f) == -inf");

    // The library's one exception type.
    try {
        throw sylva::Error("consumer");
    } catch (const std::runtime_error& e) {
        check(std::string(e.what()) == "consumer", "sylva::Error carries its message");
    }

    if (failures == 0) std::puts("sylva_consumer: OK");
    return failures == 0 ? 0 : 1;
}
