// Fillet meta-particles for the model tests. The header forward-declares the mesh so that
// the tests' headers stay free of the generator's.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include "fl/twin/dem/fillet_template.hpp"

namespace fl::dem {
struct TriangleMesh;
}

namespace fl::model_tests {

// Reads a millimetre STL fillet mesh (closed, outward); throws dem::StlError on a bad file.
std::shared_ptr<const dem::TriangleMesh> load_fillet_mesh(const std::filesystem::path& stl_mm);

// The table-3.1 variant `variant` of `base` (nullptr: the procedural dem::make_fillet_mesh(),
// equal to twin/assets/fillet_nominal.stl) filled with spheres of `radius_m`, then scaled by
// `scale` (positions, radii, contact radii: the same particles, as the thesis' scaling test).
dem::FilletTemplate make_fillet_template(const dem::TriangleMesh* base, double radius_m,
                                         std::size_t variant, double scale);
std::size_t fillet_variant_count();
std::string fillet_variant_name(std::size_t variant);

}  // namespace fl::model_tests
