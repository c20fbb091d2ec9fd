// Physical quantities and the units a measurement file may use for them. Everything is
// converted to SI on loading, so the rest of the workbench computes in one system.
//
//   const auto unit = fl::workbench::find_unit("mm");       // length, 1e-3
//   const auto value = fl::workbench::parse_quantity("0.02 N");  // force, 0.02
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace fl::workbench {

enum class Quantity : std::uint8_t {
  kDimensionless,  // ratios, counts, identifiers: "1"
  kTime,
  kLength,
  kAngle,
  kForce,
  kMass,
  kSpeed,
  kMassFlow,
  kEnergy,
  kRate,  // counts per time: fillets fed per second
  kAngularSpeed,
};

// "length", "mass flow", ...
std::string_view to_string(Quantity quantity);
// The SI unit written out: "m", "kg/s", ...
std::string_view si_unit(Quantity quantity);

struct Unit {
  std::string_view symbol;  // as written in files: "mm", "deg", "kg/min"
  Quantity quantity = Quantity::kDimensionless;
  double to_si = 1.0;  // value_si = value * to_si
};

// The unit with this symbol (exact, case-sensitive: "mN" is not "MN"); nullopt if unknown.
std::optional<Unit> find_unit(std::string_view symbol);
// "m, mm, cm, um" for messages.
std::string units_of(Quantity quantity);

struct QuantityValue {
  double value_si = 0.0;
  Unit unit;
};

// "12.5 mm", "0.02 N", "3 deg": a finite number, one or more spaces, a known unit. A bare
// number is read as dimensionless. Returns the reason when it is none of these.
struct QuantityParse {
  std::optional<QuantityValue> value;
  std::string error;
};
QuantityParse parse_quantity(std::string_view text);

}  // namespace fl::workbench
