// Sub-particle raster, types and bonds of the fillet meta-particles (thesis 3.3, appendix B).
#include "fl/twin/dem/fillet_generator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>
#include <tuple>

namespace fl::dem {
namespace {

constexpr double kPi = std::numbers::pi;
// Thesis appendix B: ~160k particles in 450 fillets.
constexpr double kThesisSpheresPerFillet = 160000.0 / 450.0;

std::vector<std::size_t> bond_counts(const FilletTemplate& fillet) {
  std::vector<std::size_t> counts(fillet.positions_m.size(), 0);
  for (const auto& bond : fillet.bonds) {
    ++counts[bond.i];
    ++counts[bond.j];
  }
  return counts;
}

// Spheres whose 26 raster neighbours all exist: interior spheres with a full bond set.
std::vector<std::size_t> interior_spheres(const FilletTemplate& fillet, double pitch_m) {
  std::set<std::tuple<long, long, long>> occupied;
  const auto key = [&](const Eigen::Vector3d& p) {
    return std::make_tuple(std::lround(p.x() / pitch_m), std::lround(p.y() / pitch_m),
                           std::lround(p.z() / pitch_m));
  };
  // Raster coordinates in the mesh frame are origin + pitch x integers; subtracting one
  // sphere's position makes them integer multiples of the pitch.
  const Eigen::Vector3d reference = fillet.positions_m.front();
  for (const auto& p : fillet.positions_m) occupied.insert(key(p - reference));
  std::vector<std::size_t> interior;
  for (std::size_t n = 0; n < fillet.positions_m.size(); ++n) {
    const auto [i, j, k] = key(fillet.positions_m[n] - reference);
    bool full = true;
    for (long di = -1; di <= 1 && full; ++di) {
      for (long dj = -1; dj <= 1 && full; ++dj) {
        for (long dk = -1; dk <= 1 && full; ++dk) {
          full = occupied.count({i + di, j + dj, k + dk}) > 0;
        }
      }
    }
    if (full) interior.push_back(n);
  }
  return interior;
}

void expect_bonds_valid(const FilletTemplate& fillet, double contact_radius_m, bool inclusive) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> seen;
  for (const auto& bond : fillet.bonds) {
    ASSERT_LT(bond.i, bond.j);
    ASSERT_LT(bond.j, fillet.positions_m.size());
    EXPECT_TRUE(seen.insert({bond.i, bond.j}).second) << "duplicate bond";
    EXPECT_NE(fillet.types[bond.i], fillet.types[bond.j]) << "same-type bond";
    EXPECT_DOUBLE_EQ(bond.contact_radius_m, contact_radius_m);
    const double distance = (fillet.positions_m[bond.i] - fillet.positions_m[bond.j]).norm();
    if (inclusive) {
      EXPECT_LE(distance, 2.0 * contact_radius_m * (1.0 + 1e-9));
    } else {
      EXPECT_LT(distance, 2.0 * contact_radius_m);
    }
  }
}

// A 40 mm cube around the origin with 4 mm spheres (pitch 8 mm) and the raster on the cube's
// centre: points at 0, +-8, +-16 mm per axis (+-24 is outside), 5^3 = 125 spheres, no point
// on the surface. Every count here is exact.
class CubeRaster : public ::testing::Test {
 protected:
  TriangleMesh cube = make_box(Eigen::Vector3d::Constant(-0.02), Eigen::Vector3d::Constant(0.02));
  static constexpr double kRadius = 0.004;
};

TEST_F(CubeRaster, CountTypesMassExtent) {
  const auto fillet = generate_fillet_template(cube, "cube");
  ASSERT_EQ(fillet.positions_m.size(), 125U);
  EXPECT_EQ(fillet.name, "cube");
  // Parity of i + j + k over {-2..2}^3: 63 even (A), 62 odd (B); the centre sphere is A.
  EXPECT_EQ(std::count(fillet.types.begin(), fillet.types.end(), kFilletTypeA), 63);
  EXPECT_EQ(std::count(fillet.types.begin(), fillet.types.end(), kFilletTypeB), 62);
  EXPECT_TRUE(std::all_of(fillet.radii_m.begin(), fillet.radii_m.end(),
                          [](double r) { return r == kRadius; }));
  // Symmetric raster: sphere centroid = cube centre, so positions are raster coordinates.
  EXPECT_LT(fillet.centroid_in_mesh_m.norm(), 1e-15);
  EXPECT_TRUE(fillet.half_extent_m.isApprox(Eigen::Vector3d::Constant(0.020), 1e-12));
  const double sphere_volume = 4.0 / 3.0 * kPi * std::pow(kRadius, 3);
  EXPECT_NEAR(fillet.mass_kg, 940.0 * 125.0 * sphere_volume, 1e-15);
  EXPECT_NEAR(fillet.particle_density_kg_m3, 940.0, 1e-9);
  EXPECT_NEAR(fillet.mesh_volume_m3, 0.04 * 0.04 * 0.04, 1e-18);
  // Each sphere has the same type as the sphere one pitch away diagonally on a face (edge
  // diagonal): type = parity.
  for (std::size_t n = 0; n < fillet.positions_m.size(); ++n) {
    const Eigen::Vector3d raster = fillet.positions_m[n] / 0.008;
    const long parity =
        (std::lround(raster.x()) + std::lround(raster.y()) + std::lround(raster.z()) + 6) %
        2;  // +6 keeps the sum non-negative
    EXPECT_EQ(fillet.types[n], parity == 0 ? kFilletTypeA : kFilletTypeB);
  }
}

// Every raster column of the cube holds 5 spheres (k = -2..2): 4 pitches plus a diameter,
// 40 mm, at every bond.
TEST_F(CubeRaster, BondsCarryTheirColumnsThickness) {
  const auto fillet = generate_fillet_template(cube, "cube");
  for (const auto& bond : fillet.bonds) EXPECT_NEAR(bond.thickness_m, 0.040, 1e-15);
}

TEST_F(CubeRaster, MatchMeshMassScalesDensity) {
  FilletGeneratorOptions options;
  options.match_mesh_mass = true;
  const auto fillet = generate_fillet_template(cube, "cube", options);
  EXPECT_NEAR(fillet.mass_kg, 940.0 * 0.04 * 0.04 * 0.04, 1e-15);
  // 125 spheres fill 125 x 4/3 pi (4 mm)^3 = 33.5 cm^3 of the 64 cm^3 cube: the density
  // rises by 64 / 33.5 = 1.91 (6 / pi for a full raster).
  EXPECT_NEAR(fillet.particle_density_kg_m3 / 940.0, 6.0 / kPi, 1e-12);
}

TEST_F(CubeRaster, ExclusiveLimitBondsFaceNeighboursOnly) {
  const auto fillet = generate_fillet_template(cube, "cube");
  // Face-neighbour pairs in a 5^3 block: 3 axes x 4 x 5 x 5 = 300. Body diagonals sit exactly
  // at 2 x r x sqrt(3) = 2 x contact radius and stay unbonded.
  EXPECT_EQ(fillet.bonds.size(), 300U);
  expect_bonds_valid(fillet, kRadius * std::sqrt(3.0), false);
  for (const auto& bond : fillet.bonds) {
    EXPECT_NEAR((fillet.positions_m[bond.i] - fillet.positions_m[bond.j]).norm(), 0.008, 1e-15);
  }
  // The centre sphere (raster 0,0,0) has 6 bonds.
  const auto counts = bond_counts(fillet);
  for (std::size_t n = 0; n < fillet.positions_m.size(); ++n) {
    if (fillet.positions_m[n].norm() < 1e-12) {
      EXPECT_EQ(counts[n], 6U);
    }
  }
}

TEST_F(CubeRaster, InclusiveLimitAddsBodyDiagonals) {
  FilletGeneratorOptions options;
  options.bond_limit = BondLimit::kInclusive;
  const auto fillet = generate_fillet_template(cube, "cube", options);
  // 300 face pairs + body-diagonal pairs: 4 diagonal directions x 4^3 = 256. Edge diagonals
  // (2r sqrt(2) = 11.3 mm < 13.9 mm) are in reach but same type: never bonded.
  EXPECT_EQ(fillet.bonds.size(), 300U + 256U);
  expect_bonds_valid(fillet, kRadius * std::sqrt(3.0), true);
  const auto counts = bond_counts(fillet);
  for (std::size_t n = 0; n < fillet.positions_m.size(); ++n) {
    if (fillet.positions_m[n].norm() < 1e-12) {
      EXPECT_EQ(counts[n], 6U + 8U);
    }
  }
}

TEST_F(CubeRaster, ThesisTableValueBondsFaceNeighboursEvenInclusive) {
  // Table B.1 gives 6.928 mm, just under 4 x sqrt(3) = 6.9282 mm: its radii do not reach the
  // body diagonals whatever the limit rule, which is why `exclusive` is the default.
  FilletGeneratorOptions options;
  options.contact_radius_factor = 6.928 / 4.0;
  options.bond_limit = BondLimit::kInclusive;
  EXPECT_EQ(generate_fillet_template(cube, "cube", options).bonds.size(), 300U);
}

TEST_F(CubeRaster, OneTypeLimitWouldAddEdgeDiagonalsButTypesPreventIt) {
  // A contact radius above r sqrt(2) reaches edge diagonals (2r sqrt(2)); they are A-A or
  // B-B pairs, so the bond count stays 300 (thesis figure 3.4 vs 3.5).
  FilletGeneratorOptions options;
  options.contact_radius_factor = 1.6;  // sqrt(2) = 1.41 < 1.6 < sqrt(3) = 1.73
  EXPECT_EQ(generate_fillet_template(cube, "cube", options).bonds.size(), 300U);
}

TEST_F(CubeRaster, RasterOffsetOfOnePitchSwapsTypes) {
  FilletGeneratorOptions shifted;
  shifted.raster_offset_m = Eigen::Vector3d(0.008, 0.0, 0.0);
  const auto base = generate_fillet_template(cube, "cube");
  const auto moved = generate_fillet_template(cube, "cube", shifted);
  // Same points (the raster is periodic), indices shifted by one: every parity flips.
  ASSERT_EQ(base.positions_m.size(), moved.positions_m.size());
  for (std::size_t n = 0; n < base.positions_m.size(); ++n) {
    EXPECT_TRUE(base.positions_m[n].isApprox(moved.positions_m[n], 1e-12) ||
                (base.positions_m[n] - moved.positions_m[n]).norm() < 1e-15);
    EXPECT_NE(base.types[n], moved.types[n]);
  }
  // An offset of 3 mm puts the raster at -13, -5, 3, 11, 19 mm: still 5^3, no longer centred.
  shifted.raster_offset_m = Eigen::Vector3d::Constant(0.003);
  const auto off_centre = generate_fillet_template(cube, "cube", shifted);
  EXPECT_EQ(off_centre.positions_m.size(), 125U);
  EXPECT_TRUE(off_centre.centroid_in_mesh_m.isApprox(Eigen::Vector3d::Constant(0.003), 1e-9));
}

TEST_F(CubeRaster, SphereInsideDropsTheOuterLayer) {
  FilletGeneratorOptions options;
  options.inclusion = RasterInclusion::kSphereInside;
  // The +-16 mm layer touches the faces exactly (16 + 4 = 20 mm), a rounding tie; 1 nm of
  // allowed protrusion keeps it.
  options.sphere_protrusion_m = 1e-9;
  EXPECT_EQ(generate_fillet_template(cube, "cube", options).positions_m.size(), 125U);
  options.sub_particle_radius_m = 0.0045;  // pitch 9: points at 0, +-9, +-18; 18 + 4.5 > 20
  EXPECT_EQ(generate_fillet_template(cube, "cube", options).positions_m.size(), 27U);
  options.sphere_protrusion_m = 0.003;  // now 18 + 4.5 - 3 < 20: the layer is back
  EXPECT_EQ(generate_fillet_template(cube, "cube", options).positions_m.size(), 125U);
}

TEST_F(CubeRaster, BadInputIsRefused) {
  FilletGeneratorOptions options;
  options.sub_particle_radius_m = 0.0;
  EXPECT_THROW(generate_fillet_template(cube, "x", options), std::invalid_argument);
  options = {};
  options.contact_radius_factor = 0.9;
  EXPECT_THROW(generate_fillet_template(cube, "x", options), std::invalid_argument);
  options = {};
  options.density_kg_m3 = -1.0;
  EXPECT_THROW(generate_fillet_template(cube, "x", options), std::invalid_argument);
  EXPECT_THROW(generate_fillet_template(flipped(cube), "x"), std::invalid_argument);
  auto open = cube;
  open.triangles.pop_back();
  EXPECT_THROW(generate_fillet_template(open, "x"), std::invalid_argument);
  options = {};
  options.sub_particle_radius_m = 0.05;  // pitch 10 cm: only the centre point, inside
  EXPECT_EQ(generate_fillet_template(cube, "x", options).positions_m.size(), 1U);
  options.raster_offset_m = Eigen::Vector3d::Constant(0.05);  // no point inside the cube
  EXPECT_THROW(generate_fillet_template(cube, "x", options), std::runtime_error);
}

// --- The fillet ------------------------------------------------------------------------

class NominalFillet : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new TriangleMesh(make_fillet_mesh());
    fillet_ = new FilletTemplate(generate_fillet_template(*mesh_, "s172x72x32_left"));
  }
  static void TearDownTestSuite() {
    delete fillet_;
    delete mesh_;
  }
  static TriangleMesh* mesh_;
  static FilletTemplate* fillet_;
};
TriangleMesh* NominalFillet::mesh_ = nullptr;
FilletTemplate* NominalFillet::fillet_ = nullptr;

TEST_F(NominalFillet, EverySphereCentreIsInsideTheMesh) {
  for (const auto& p : fillet_->positions_m) {
    EXPECT_TRUE(contains_point(*mesh_, p + fillet_->centroid_in_mesh_m));
  }
}

TEST_F(NominalFillet, PositionsAreRelativeToTheirCentroid) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : fillet_->positions_m) sum += p;
  EXPECT_LT(sum.norm() / static_cast<double>(fillet_->positions_m.size()), 1e-15);
  // The spheres' centroid is near the mesh centroid (the origin): within a quarter pitch.
  EXPECT_LT(fillet_->centroid_in_mesh_m.norm(), 0.002);
  for (const auto& p : fillet_->positions_m) {
    EXPECT_TRUE((p.cwiseAbs().array() + 0.004 <= fillet_->half_extent_m.array() + 1e-15).all());
  }
}

TEST_F(NominalFillet, CountNearVolumeOverPitchCubed) {
  // Centre-inside keeps a raster point per lattice cell whose centre is inside: averaged over
  // raster phases the count is exactly volume / pitch^3. The 8 half-pitch phases together are
  // one raster of pitch 4 mm (~3200 points), whose surface error is ~2 %: 3 % bound. A single
  // phase (~400 points, surface error ~ +-surface x pitch / 2 / volume) gets 6 %.
  const double expected = signed_volume(*mesh_) / std::pow(0.008, 3);
  EXPECT_NEAR(static_cast<double>(fillet_->positions_m.size()) / expected, 1.0, 0.06);
  double total = 0.0;
  for (int phase = 0; phase < 8; ++phase) {
    FilletGeneratorOptions options;
    options.raster_offset_m =
        0.004 * Eigen::Vector3d((phase & 1) != 0 ? 1.0 : 0.0, (phase & 2) != 0 ? 1.0 : 0.0,
                                (phase & 4) != 0 ? 1.0 : 0.0);
    total += static_cast<double>(generate_fillet_template(*mesh_, "p", options).positions_m.size());
  }
  EXPECT_NEAR(total / 8.0 / expected, 1.0, 0.03);
}

TEST_F(NominalFillet, CountNearThesis) {
  // The thesis' bulk run: 450 fillets, "over 160k" spheres, ~356 per fillet at r = 4 mm,
  // averaged over its six types. The nominal fillet (a middle size) with centre-inside gets
  // ~390 (mesh volume 201.5 cm^3 / 512 mm^3 per sphere); within -20 %..+25 % of the thesis.
  const auto count = static_cast<double>(fillet_->positions_m.size());
  EXPECT_GT(count, 0.80 * kThesisSpheresPerFillet);
  EXPECT_LT(count, 1.25 * kThesisSpheresPerFillet);
  RecordProperty("nominal_spheres", static_cast<int>(count));
}

TEST_F(NominalFillet, BondsAreAbOnlyWithinContactRadius) {
  expect_bonds_valid(*fillet_, 0.004 * std::sqrt(3.0), false);
  // 6 bonds at interior spheres (face neighbours; see BondLimit::kExclusive), fewer at the
  // surface, none without any neighbour.
  const auto counts = bond_counts(*fillet_);
  const auto interior = interior_spheres(*fillet_, 0.008);
  ASSERT_GT(interior.size(), 10U);  // a 32 mm thick fillet has a core of whole 3x3x3 blocks
  for (const auto n : interior) EXPECT_EQ(counts[n], 6U);
  EXPECT_LE(*std::max_element(counts.begin(), counts.end()), 6U);
  EXPECT_GE(*std::min_element(counts.begin(), counts.end()), 1U) << "a loose sphere";
}

// The fillet tapers from its thick end (-x) to its tip (+x): bonds in the rear third sit in
// thicker columns than bonds in the tip third (25.0 against 20.9 mm on the nominal mesh at
// 4 mm spheres: 10 % is a margin no rounding of the raster reaches), and no bond is thicker
// than the fillet's bounding box nor thinner than one sphere.
TEST_F(NominalFillet, BondThicknessFollowsTheTaperFromRearToTip) {
  const double length_m = 2.0 * fillet_->half_extent_m.x();
  double rear_sum = 0.0, tip_sum = 0.0;
  int rear = 0, tip = 0;
  for (const auto& bond : fillet_->bonds) {
    EXPECT_GE(bond.thickness_m, 0.008 - 1e-15);
    EXPECT_LE(bond.thickness_m, 2.0 * fillet_->half_extent_m.z() + 1e-15);
    const double x = 0.5 * (fillet_->positions_m[bond.i].x() + fillet_->positions_m[bond.j].x());
    if (x < -length_m / 6.0) {
      rear_sum += bond.thickness_m;
      ++rear;
    } else if (x > length_m / 6.0) {
      tip_sum += bond.thickness_m;
      ++tip;
    }
  }
  ASSERT_GT(rear, 0);
  ASSERT_GT(tip, 0);
  EXPECT_GT(rear_sum / rear, 1.1 * tip_sum / tip);
  RecordProperty("rear_mean_thickness_mm", std::to_string(1e3 * rear_sum / rear));
  RecordProperty("tip_mean_thickness_mm", std::to_string(1e3 * tip_sum / tip));
}

TEST_F(NominalFillet, InclusiveLimitGivesFourteenBondsInside) {
  FilletGeneratorOptions options;
  options.bond_limit = BondLimit::kInclusive;
  const auto fillet = generate_fillet_template(*mesh_, "inclusive", options);
  EXPECT_EQ(fillet.positions_m.size(), fillet_->positions_m.size());
  expect_bonds_valid(fillet, 0.004 * std::sqrt(3.0), true);
  const auto counts = bond_counts(fillet);
  for (const auto n : interior_spheres(fillet, 0.008)) EXPECT_EQ(counts[n], 14U);
}

TEST_F(NominalFillet, SphereInsideKeepsEverySphereInside) {
  FilletGeneratorOptions options;
  options.inclusion = RasterInclusion::kSphereInside;
  const auto fillet = generate_fillet_template(*mesh_, "inside", options);
  for (const auto& p : fillet.positions_m) {
    const Eigen::Vector3d centre = p + fillet.centroid_in_mesh_m;
    EXPECT_TRUE(contains_point(*mesh_, centre));
    EXPECT_GE(distance_to_surface(*mesh_, centre), 0.004);
  }
  // The shape shrinks by a radius all round: far fewer spheres than centre-inside.
  EXPECT_LT(fillet.positions_m.size(), fillet_->positions_m.size() * 3 / 4);
}

TEST_F(NominalFillet, MassFromSpheresOrMesh) {
  const double spheres_volume =
      static_cast<double>(fillet_->positions_m.size()) * 4.0 / 3.0 * kPi * std::pow(0.004, 3);
  EXPECT_NEAR(fillet_->mass_kg, 940.0 * spheres_volume, 1e-12);
  FilletGeneratorOptions options;
  options.match_mesh_mass = true;
  const auto heavy = generate_fillet_template(*mesh_, "heavy", options);
  EXPECT_NEAR(heavy.mass_kg, 940.0 * signed_volume(*mesh_), 1e-12);
  // The sphere raster fills ~pi/6 of the mesh: the particle density nearly doubles.
  EXPECT_NEAR(heavy.particle_density_kg_m3 / 940.0, 6.0 / kPi, 0.15);
}

TEST_F(NominalFillet, Reproducible) {
  const auto again = generate_fillet_template(*mesh_, "s172x72x32_left");
  ASSERT_EQ(again.positions_m.size(), fillet_->positions_m.size());
  for (std::size_t n = 0; n < again.positions_m.size(); ++n) {
    EXPECT_EQ(again.positions_m[n], fillet_->positions_m[n]);
    EXPECT_EQ(again.types[n], fillet_->types[n]);
  }
  ASSERT_EQ(again.bonds.size(), fillet_->bonds.size());
  for (std::size_t n = 0; n < again.bonds.size(); ++n) {
    EXPECT_EQ(again.bonds[n].i, fillet_->bonds[n].i);
    EXPECT_EQ(again.bonds[n].j, fillet_->bonds[n].j);
  }
}

TEST(FilletGenerator, SixVariantsLeftRightMirrorImages) {
  const auto templates = generate_thesis_fillets(make_fillet_mesh());
  ASSERT_EQ(templates.size(), 6U);
  for (std::size_t pair = 0; pair < 3; ++pair) {
    const auto& left = templates[2 * pair];
    const auto& right = templates[2 * pair + 1];
    EXPECT_EQ(left.name.substr(left.name.size() - 5), "_left");
    EXPECT_EQ(right.name.substr(right.name.size() - 6), "_right");
    ASSERT_EQ(left.positions_m.size(), right.positions_m.size()) << left.name;
    EXPECT_EQ(left.bonds.size(), right.bonds.size());
    EXPECT_NEAR(left.mass_kg, right.mass_kg, 1e-15);
    // Match each left sphere mirrored (y -> -y) to a right sphere of the same type. Positions
    // are rounded to 1 um for the lookup; mirror errors are ~1e-17 m.
    std::map<std::tuple<long, long, long>, std::uint8_t> right_spheres;
    for (std::size_t n = 0; n < right.positions_m.size(); ++n) {
      const auto& p = right.positions_m[n];
      right_spheres[{std::lround(p.x() * 1e6), std::lround(p.y() * 1e6),
                     std::lround(p.z() * 1e6)}] = right.types[n];
    }
    for (std::size_t n = 0; n < left.positions_m.size(); ++n) {
      const auto& p = left.positions_m[n];
      const auto found = right_spheres.find(
          {std::lround(p.x() * 1e6), std::lround(-p.y() * 1e6), std::lround(p.z() * 1e6)});
      ASSERT_NE(found, right_spheres.end()) << left.name << " sphere " << n;
      EXPECT_EQ(found->second, left.types[n]);
    }
  }
}

TEST(FilletGenerator, CountsPerVariantAndRadius) {
  // Record (and sanity-check) the sphere counts: each within 10 % of volume / pitch^3 for
  // r = 4 mm; the bond count per sphere below 3 (6 per interior sphere, shared by 2).
  const auto base = make_fillet_mesh();
  for (const auto& variant : thesis_fillet_variants()) {
    if (variant.side == FilletSide::kRight) continue;  // mirror images, same counts
    const auto mesh = make_variant_mesh(base, variant);
    const auto fillet = generate_fillet_template(mesh, variant.name);
    const double count = static_cast<double>(fillet.positions_m.size());
    const double expected = signed_volume(mesh) / std::pow(0.008, 3);
    EXPECT_NEAR(count / expected, 1.0, 0.10) << variant.name;
    EXPECT_LT(static_cast<double>(fillet.bonds.size()), 3.0 * count);
    std::printf("%s: %zu spheres (volume / pitch^3 = %.0f), %zu bonds, %.0f g\n",
                variant.name.c_str(), fillet.positions_m.size(), expected, fillet.bonds.size(),
                fillet.mass_kg * 1e3);
  }
}

}  // namespace
}  // namespace fl::dem
