// The DEM twin as a TrialModel: each experiment of the thesis' model tests reproduced from a
// trial's conditions and driving channels. The engine model (contact and bond laws, effects
// from the effect library) comes from CommonParams::base_spec, so adding an effect to the
// model is a change of that spec (config/dem.yaml), not of this code.
#pragma once

#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/compare.hpp"

namespace fl::workbench {

// Compression of a bonded block between plates: the top plate follows the measured
// displacement over the measured times (load, hold, unload as measured), the plate force is
// the model's answer. Sample size from the trial's sample_side and sample_height conditions
// (default 5 x 5 x 4 sub-particles).
class TwinCompressModel final : public TrialModel {
 public:
  explicit TwinCompressModel(model_tests::CommonParams common);
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
};

}  // namespace fl::workbench
