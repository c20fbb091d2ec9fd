#include "fl/workbench/units.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <numbers>

#include "text.hpp"

namespace fl::workbench {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

constexpr std::array kUnits{
    Unit{"1", Quantity::kDimensionless, 1.0},
    Unit{"-", Quantity::kDimensionless, 1.0},
    Unit{"s", Quantity::kTime, 1.0},
    Unit{"ms", Quantity::kTime, 1e-3},
    Unit{"min", Quantity::kTime, 60.0},
    Unit{"m", Quantity::kLength, 1.0},
    Unit{"cm", Quantity::kLength, 1e-2},
    Unit{"mm", Quantity::kLength, 1e-3},
    Unit{"um", Quantity::kLength, 1e-6},
    Unit{"rad", Quantity::kAngle, 1.0},
    Unit{"deg", Quantity::kAngle, kDegree},
    Unit{"N", Quantity::kForce, 1.0},
    Unit{"mN", Quantity::kForce, 1e-3},
    Unit{"kN", Quantity::kForce, 1e3},
    Unit{"kg", Quantity::kMass, 1.0},
    Unit{"g", Quantity::kMass, 1e-3},
    Unit{"m/s", Quantity::kSpeed, 1.0},
    Unit{"mm/s", Quantity::kSpeed, 1e-3},
    Unit{"m/min", Quantity::kSpeed, 1.0 / 60.0},
    Unit{"kg/s", Quantity::kMassFlow, 1.0},
    Unit{"kg/min", Quantity::kMassFlow, 1.0 / 60.0},
    Unit{"kg/h", Quantity::kMassFlow, 1.0 / 3600.0},
    Unit{"g/s", Quantity::kMassFlow, 1e-3},
    Unit{"J", Quantity::kEnergy, 1.0},
    Unit{"mJ", Quantity::kEnergy, 1e-3},
    Unit{"1/s", Quantity::kRate, 1.0},
    Unit{"1/min", Quantity::kRate, 1.0 / 60.0},
    Unit{"1/h", Quantity::kRate, 1.0 / 3600.0},
    Unit{"rad/s", Quantity::kAngularSpeed, 1.0},
    Unit{"deg/s", Quantity::kAngularSpeed, kDegree},
};

}  // namespace

std::string_view to_string(Quantity quantity) {
  switch (quantity) {
    case Quantity::kDimensionless:
      return "dimensionless";
    case Quantity::kTime:
      return "time";
    case Quantity::kLength:
      return "length";
    case Quantity::kAngle:
      return "angle";
    case Quantity::kForce:
      return "force";
    case Quantity::kMass:
      return "mass";
    case Quantity::kSpeed:
      return "speed";
    case Quantity::kMassFlow:
      return "mass flow";
    case Quantity::kEnergy:
      return "energy";
    case Quantity::kRate:
      return "rate";
    case Quantity::kAngularSpeed:
      return "angular speed";
  }
  return "unknown";
}

std::string_view si_unit(Quantity quantity) {
  for (const Unit& unit : kUnits) {
    if (unit.quantity == quantity && unit.to_si == 1.0) return unit.symbol;
  }
  return "?";
}

std::optional<Unit> find_unit(std::string_view symbol) {
  for (const Unit& unit : kUnits) {
    if (unit.symbol == symbol) return unit;
  }
  return std::nullopt;
}

std::string units_of(Quantity quantity) {
  std::string list;
  for (const Unit& unit : kUnits) {
    if (unit.quantity != quantity) continue;
    if (!list.empty()) list += ", ";
    list += unit.symbol;
  }
  return list;
}

QuantityParse parse_quantity(std::string_view text) {
  const std::string_view trimmed = detail::trim(text);
  double number = 0.0;
  const char* begin = trimmed.data();
  const char* end = trimmed.data() + trimmed.size();
  const auto [rest, error] = std::from_chars(begin, end, number);
  if (error != std::errc{} || rest == begin) {
    return {std::nullopt, "'" + std::string(text) + "' does not start with a number"};
  }
  if (!std::isfinite(number)) {
    return {std::nullopt, "'" + std::string(text) + "' is not a finite number"};
  }
  const std::string_view symbol =
      detail::trim(std::string_view(rest, static_cast<std::size_t>(end - rest)));
  if (symbol.empty()) return {QuantityValue{number, *find_unit("1")}, {}};
  if (rest == end || (*rest != ' ' && *rest != '\t')) {
    return {std::nullopt, "'" + std::string(text) + "': put a space between number and unit"};
  }
  const std::optional<Unit> unit = find_unit(symbol);
  if (!unit) {
    return {std::nullopt,
            "'" + std::string(text) + "': unknown unit '" + std::string(symbol) + "'"};
  }
  return {QuantityValue{number * unit->to_si, *unit}, {}};
}

}  // namespace fl::workbench
