// sylva/core/error.hpp -- the one exception type the library throws.
#ifndef SYLVA_CORE_ERROR_HPP
#define SYLVA_CORE_ERROR_HPP

#include <stdexcept>
#include <string>

namespace sylva {

/// Thrown for bad input (malformed files, NaN bounds, corrupted encodings) and unavailable
/// resources (no Vulkan device). The message names the problem and, where there is one, the file.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace sylva

#endif  // SYLVA_CORE_ERROR_HPP
