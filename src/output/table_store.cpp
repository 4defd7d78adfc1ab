#include "stickslip/output/table_store.hpp"

#include <charconv>
#include <stdexcept>
#include <string>
#include <system_error>

namespace stickslip {

std::string csv_file_name(std::string_view table) {
  return std::string(table) + ".csv";
}

std::string member_column(std::string_view dataset, int member) {
  return std::string(dataset) + "_" + std::to_string(member);
}

std::optional<int> column_member(std::string_view name, std::string_view dataset) {
  if (name.size() <= dataset.size() + 1 || name.substr(0, dataset.size()) != dataset ||
      name[dataset.size()] != '_')
    return std::nullopt;
  const std::string_view digits = name.substr(dataset.size() + 1);
  int member = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), member);
  if (error != std::errc() || end != digits.data() + digits.size() || member < 0)
    return std::nullopt;
  return member;
}

void check_row(std::span<const double> row, std::size_t columns) {
  if (row.size() != columns)
    throw std::logic_error("a table row of " + std::to_string(row.size()) + " values for " +
                           std::to_string(columns) + " columns");
}

}  // namespace stickslip
