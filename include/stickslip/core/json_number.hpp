#pragma once
// JSON has no NaN or infinity: an undefined number (a statistic with no data,
// a difference of runs that could not be compared) is written as null.

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

namespace stickslip {

inline nlohmann::json number_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

inline nlohmann::json number_or_null(const std::optional<double>& x) {
  return x ? number_or_null(*x) : nlohmann::json(nullptr);
}

}  // namespace stickslip
