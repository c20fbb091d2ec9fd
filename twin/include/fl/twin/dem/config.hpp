// DEM parameters: the thesis' appendix B as code defaults and as config/dem.yaml.
#pragma once

#include <filesystem>

#include "fl/twin/dem/model.hpp"

namespace fl::dem {

// Appendix B: fillet material (E = 3.7e5 Pa, nu = 0.37, rho = 940), types fillet_a and fillet_b
// (A-B bonds only, contact radius 4*sqrt(3) mm), steel equipment (type equipment), Hertz-Mindlin
// with restitution 1e-4, JKR 0.055 J/m^2, Coulomb 0.1 fillet-fillet and 0.5 fillet-equipment,
// BPM 1e6 / 6e4 N/m^3, strengths 1e300 Pa, timestep 15% Rayleigh of a 4 mm sphere.
ModelSpec appendix_b_model_spec();
inline constexpr double kAppendixBContactRadiusM = 0.004 * 1.7320508075688772;

// Reads config/dem.yaml strictly (fl::YamlReader); throws fl::ConfigError listing problems.
ModelSpec load_model_spec(const std::filesystem::path& yaml_file,
                          const LawRegistry& registry = LawRegistry::builtin());

}  // namespace fl::dem
