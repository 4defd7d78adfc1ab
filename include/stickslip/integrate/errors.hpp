#pragma once
// What a failed run throws, apart from SUNDIALS' headers (sundials.hpp) so
// that the command line and the Python module catch it without them.

#include <stdexcept>

namespace stickslip {

// Thrown when an integrator fails; `what()` says where (time) and why.
class IntegrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace stickslip
