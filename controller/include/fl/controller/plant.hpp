// The plant interface: what the controller runs against. The fast 2D plant (twin/fast) and
// the DEM twin (twin/dem) implement it; in two-process mode the drivers' device emulation
// wraps one. A plant consumes the controller's output image and produces the next input
// image, so it stands exactly where the real line's drives, I/O and cameras stand.
#pragma once

#include <cstdint>
#include <span>

#include "fl/controller/process_image.hpp"

namespace fl {

// Where a fillet physically ended, according to the plant's ground truth. The controller
// never sees this; KPIs compare it with the controller's own ledger.
enum class TrueExit : std::uint8_t {
  kOutfeed,      // handed over past the end of the outfeed
  kRejectCrate,  // dropped by a reject-belt reversal
  kFinalReject,  // blown off by the final air knife
  kFellOff,      // left the belt sideways or got stuck (a plant-side loss)
};

struct TrueFilletExit {
  std::uint32_t plant_id = 0;  // the plant's own fillet number
  std::uint32_t group_id = 0;  // fillets touching each other share a group id
  std::int64_t time_ns = 0;
  TrueExit exit = TrueExit::kOutfeed;
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;  // true side up at exit
  float angle_rad = 0.0F;          // true angle at exit, same convention as estimates
  float y_mm = 0.0F;               // true lateral position at exit
  bool singulated = true;          // false when it left as part of a touching group
  bool squeezed_ok = true;         // roller lowered behind the thickest section
};

class Plant {
 public:
  Plant() = default;
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;
  virtual ~Plant() = default;

  // Short name for logs and KPI files ("fast", "dem").
  [[nodiscard]] virtual const char* name() const = 0;

  // Restart from an empty line with the given seed; afterwards `in` holds time 0.
  virtual void reset(std::uint64_t seed, InputImage& in) = 0;

  // Apply `out` for dt_ns of plant time, then write the sensors' view at the new time.
  virtual void step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) = 0;

  // Fillets that left the line since the last call; the span stays valid until the next
  // step() or reset().
  [[nodiscard]] virtual std::span<const TrueFilletExit> drain_exits() = 0;

  // Fillets that have crossed the takt barrier (s > 0) so far, and those of them still on
  // the line, so that a run can check that nothing vanished: fed = exits + on line.
  [[nodiscard]] virtual std::uint64_t fillets_fed() const = 0;
  [[nodiscard]] virtual std::uint64_t fillets_on_line() const = 0;
};

}  // namespace fl
