// The bonds follow the particles: each re-ordering of the particles by cell re-orders the bonds
// by law, then by their lower particle index (Simulation::sort_bonds), and every bond keeps its
// two particles, its rest length and its history.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <utility>

#include "dem_test_support.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {
namespace {

using test::kRadius;

// Types: 0 and 2 are two kinds of bonded block, each with its own bond law; 1 is the floor.
ModelSpec two_law_model(int threads, int sort_every_rebuilds) {
  ModelSpec spec = test::ball_model({test::hertz(0.3), test::coulomb(0.5)}, 1.678512e-4,
                                    Vec3(0, 0, -9.81), true);
  spec.types = {{"block_a", 0}, {"wall", 0}, {"block_b", 0}};
  const std::vector<LawSpec> laws = {test::hertz(0.3), test::coulomb(0.5)};
  spec.interactions = {{0, 0, laws, test::bpm(1e6, 6e5), false},
                       {0, 1, laws, std::nullopt, false},
                       {0, 2, laws, std::nullopt, false},
                       {1, 2, laws, std::nullopt, false},
                       {2, 2, laws, test::bpm(2e6, 3e5), false}};
  spec.thread_count = threads;
  spec.min_particles_per_thread = 1;
  spec.sort_every_rebuilds = sort_every_rebuilds;
  return spec;
}

// Two 5x4x3 blocks, one of each type, bonded to face and edge neighbours (the body diagonal
// sits at the break distance of two contact radii), the bonds listed in shuffled order, thrown
// apart spinning so that the particles move across cells and are re-ordered. They start 15 and 20
// cm up: in the 100 ms the tests run they neither meet each other nor the floor.
void add_blocks(Simulation& sim) {
  const std::vector<Vec3> positions = test::block_5x4x3_positions();
  std::vector<BodyBond> bonds = test::block_bonds(positions, std::sqrt(2.0));
  std::mt19937 random(7);
  const std::vector<double> radii(positions.size(), kRadius);
  for (const std::uint8_t type : {std::uint8_t{0}, std::uint8_t{2}}) {
    std::shuffle(bonds.begin(), bonds.end(), random);
    const std::vector<std::uint8_t> types(positions.size(), type);
    BodyPose pose;
    pose.position_m = Vec3(type == 0 ? 0.0 : 0.06, 0.0, 0.15 + 0.025 * type);
    pose.orientation =
        Eigen::Quaterniond(Eigen::AngleAxisd(0.4 + type, Vec3(1, 2, 0).normalized()));
    pose.velocity_m_per_s = Vec3(type == 0 ? -0.4 : 0.4, 0.1, 0.0);
    pose.angular_velocity_rad_per_s = Vec3(3.0, -2.0, 4.0);
    sim.add_body(positions, radii, types, bonds, pose);
  }
}

// A bond by the ids of its particles (ids do not change when the particles are re-ordered).
using IdPair = std::pair<std::uint32_t, std::uint32_t>;
std::map<IdPair, double> rest_lengths_by_ids(const State& s) {
  std::map<IdPair, double> out;
  for (const Bond& bond : s.bonds) out[{s.id[bond.i], s.id[bond.j]}] = bond.rest_length_m;
  return out;
}

TEST(DemBondOrder, BondsFollowTheParticlesByLawThenLowerIndex) {
  for (const int threads : {1, 2}) {
    Simulation sim(std::make_shared<Model>(two_law_model(threads, 1)));
    add_blocks(sim);
    const std::map<IdPair, double> created = rest_lengths_by_ids(sim.state());
    sim.step(600);
    const State& s = sim.state();
    ASSERT_GT(sim.stats().particle_sorts, 1U);
    ASSERT_EQ(sim.stats().broken_bonds, 0U);  // a bond that broke would be kept all the same
    // by law (block_a's bonds first: type pair (0, 0) before (2, 2)), then by lower index
    for (std::size_t k = 0; k + 1 < s.bonds.size(); ++k) {
      const Bond& a = s.bonds[k];
      const Bond& b = s.bonds[k + 1];
      const std::uint32_t law_a = s.type[a.i];
      const std::uint32_t law_b = s.type[b.i];
      ASSERT_LE(law_a, law_b) << k;
      if (law_a == law_b) {
        ASSERT_LE(std::min(a.i, a.j), std::min(b.i, b.j)) << k;
      }
    }
    // the same bonds, each between the same two particles, in the same direction
    EXPECT_EQ(rest_lengths_by_ids(s), created);
    // one run of each law per thread at most: two laws over the threads' shares
    EXPECT_LE(sim.stats().bond_law_runs, static_cast<std::size_t>(threads) + 1U);
  }
}

// The re-ordering changes the order in which forces are summed, nothing else: the blocks fly
// as they fly without it, to rounding. The bonds carry the spin's load throughout.
TEST(DemBondOrder, ReorderingChangesOnlyTheRounding) {
  std::vector<std::map<std::uint32_t, Vec3>> positions_by_id;
  for (const int sort_every : {0, 1}) {
    Simulation sim(std::make_shared<Model>(two_law_model(2, sort_every)));
    add_blocks(sim);
    sim.step(300);
    EXPECT_EQ(sim.stats().particle_sorts > 0, sort_every > 0);
    std::map<std::uint32_t, Vec3> by_id;
    for (std::size_t k = 0; k < sim.state().size(); ++k) {
      by_id[sim.state().id[k]] = sim.state().position_m[k];
    }
    positions_by_id.push_back(by_id);
  }
  ASSERT_EQ(positions_by_id[0].size(), positions_by_id[1].size());
  for (const auto& [id, position] : positions_by_id[0]) {
    // Seen: up to 1e-16 m, a few units in the last place of a 15 cm coordinate. A summation
    // order that mattered would show at the bonds' stretch, about 1e-6 m.
    EXPECT_LT((position - positions_by_id[1].at(id)).norm(), 1e-14) << id;
  }
}

}  // namespace
}  // namespace fl::dem
