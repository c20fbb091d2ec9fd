// Configuration of the DEM plant (DemPlant): what the DEM twin needs beyond the line
// configuration. Plain data with defaults; config/plant_dem.yaml holds the same values and
// load_dem_plant_config() reads it strictly (fl::YamlReader).
//
// Two parts come from other files on purpose, so that the twins cannot drift apart:
// - the DEM engine's materials, laws and solver settings (config/dem.yaml, thesis appendix B);
// - the cameras, the levelled layer on the takt belt, the hopper and leveller, and the drive
//   delay (config/plant_fast.yaml): the DEM plant's sensors behave as the fast plant's.
// A third, the bulk end as a DEM scene (config/bulk_line.yaml: hopper, bulk belt, leveller),
// feeds the takt belt instead of the levelled-layer model when DemFeederConfig::source says so.
#pragma once

#include <cstdint>
#include <filesystem>

#include "fl/twin/dem/model.hpp"
#include "fl/twin/dem_bulk/bulk_scene.hpp"
#include "fl/twin/fast_plant_config.hpp"

namespace fl {

struct DemSimulationConfig {
  // Thesis 3.3: 3..7 mm; 4 mm was the thesis' choice, 7 mm runs about 6x faster (fewer and
  // larger spheres, a longer Rayleigh step).
  float sub_particle_radius_mm = 7.0F;
  // Timestep as a share of the sub-particle's Rayleigh time (appendix B: 15 %).
  float rayleigh_fraction = 0.15F;
  // Verlet skin: a larger skin rebuilds the neighbour list less often on the moving belts
  // (every skin of travel past the line's meshes) at the price of longer lists.
  float neighbor_skin_mm = 4.0F;
  int thread_count = 2;  // results are bit-identical for a fixed count
  // A second thread from twice this many spheres. A line's few hundred to two thousand spheres
  // carry ten bonds each, and two threads ran the 7 mm line 1.5x to 1.7x faster from 700
  // spheres on; the engine's own default (2048, config/dem.yaml) keeps small lab scenes on one.
  int min_particles_per_thread = 256;
  // Machine commands, events and camera exposures are resolved at this step (the fast plant's
  // 1 ms); the engine runs its own, shorter steps in between.
  float control_step_s = 0.001F;
  std::uint32_t max_fillets = 64;  // a limit, not an allocation: the 6 m line holds about 20
  std::uint32_t exit_capacity = 1024;
  bool operator==(const DemSimulationConfig&) const = default;
};

// What centres a fillet at line.yaml's centring station.
enum class DemCentringUnit : std::uint8_t {
  // One belt-faced plate meets the fillet's outermost point and travels the commanded shift.
  // An angled fillet is met at its corner and partly turns instead of moving (docs/twin.md).
  kPusher,
  // Two belt-faced plates close on the fillet from both sides, coupled so that they meet on
  // the belt's centre line, until both press it with grip_force_n (a force-limited gripper).
  // Where they stop does not depend on where they touch: the fillet's outline ends centred.
  kJaws,
};

struct DemMachineryConfig {
  float belt_half_width_mm = 200.0F;  // 400 mm belts, the fast plant's
  // Gaps between consecutive belts and between the two belts of a multilane unit: coplanar
  // meshes that touch would both report the same edge contact (double support at the seam).
  float belt_gap_mm = 2.0F;
  float multilane_gap_mm = 2.0F;
  float side_wall_height_mm = 100.0F;  // keeps fillets on the belts
  // Guide rails: from the belt edges to a channel of +-this, over the funnel length.
  float rail_channel_half_width_mm = 100.0F;  // wider than the longest fillet: nothing jams
  float rail_funnel_length_mm = 500.0F;
  float rail_height_mm = 80.0F;
  // Centring pusher: a vertical plate along the travel direction.
  float pusher_half_length_mm = 100.0F;
  float pusher_height_mm = 60.0F;
  float pusher_window_half_mm = 60.0F;  // the fillet it strokes against, around the unit
  // Acceleration of the centring plates (its top speed is max shift / stroke time).
  float pusher_accel_mps2 = 4.0F;
  // Their braking. Under the deceleration friction gives a sliding fillet (3.2 to 4.8 m/s^2 by
  // size and direction for the DEM fillet, whose bottom spheres roll; not the rigid mu g of
  // 4.9) the fillet stops with the plate: 2.5 does so for every size. Over it, thick fillets
  // slide on past the shift, which carries those beyond the stroke's reach further in: the
  // shipped 4.0 does (docs/twin.md, "Why a pushed fillet slides on").
  float pusher_brake_mps2 = 4.0F;
  DemCentringUnit centring_unit = DemCentringUnit::kPusher;
  // Jaws: each presses the fillet at least this hard before they stop closing; over the
  // fillet's sliding friction on the belt (mu m g, 0.5 x 0.3 kg x 9.81 = 1.5 N), which the one
  // jaw that pushes alone feels, so only a fillet held from both sides stops them.
  float jaw_grip_force_n = 5.0F;
  // Jaws close at most to this half gap (nothing between them).
  float jaw_min_half_gap_mm = 15.0F;
  // The jaws' length along the travel (half). Closing from a fillet's outer side takes up to
  // 0.2 s, in which the fillet runs 100 mm at 0.5 m/s: jaws as short as the pusher let it
  // leave before they met.
  float jaw_half_length_mm = 200.0F;
  // Squeeze roller: a cylinder across the belt; bottom this high above the belt when up / down.
  float roller_radius_mm = 40.0F;
  float roller_up_gap_mm = 80.0F;
  float roller_down_gap_mm = 25.0F;
  int roller_segments = 24;
  // Height of the takt laser beam over the belt.
  float beam_height_mm = 10.0F;
  // Levels of the product path (thesis 5.3): the guide belt rises by guide_rise_mm to its end;
  // flip plate 1 is a slide over the whole plates section, down plate1_drop_mm to the reject
  // belt's level (z = 0, everything downstream too). Swung out of the way it leaves the drop
  // open: the fillet falls over the guide's end onto the landing under it and turns over.
  // 150 mm turned every thesis variant end over end at the guide's 0.5 m/s on the 7 mm twin;
  // 100 mm turned only the thin one. The rise is gentle (2.9 degrees over the 1 m guide): at
  // 150 mm (8.5 degrees) fillets bunched at the incline's foot, and camera 1 saw five times
  // as many touching or unclassifiable fillets in the closed loop.
  float guide_rise_mm = 50.0F;
  float plate1_drop_mm = 150.0F;
  // The slide ends this high over the reject belt, higher than the thickest fillet (40 mm):
  // a fillet the reversing belt carries back passes under it into the crate. Ending on the
  // belt, the slide and the landing made a wedge that crushed such a fillet.
  float plate1_end_height_mm = 50.0F;
  // Plate 1 swings up about its hinge along the belt's right edge by this angle to open.
  float plate_swing_deg = 90.0F;
  bool operator==(const DemMachineryConfig&) const = default;
};

struct DemLossConfig {
  float fell_below_mm = -50.0F;  // centroid under this height: fell between or off the belts
  // A fed fillet that does not advance stuck_progress_mm in stuck_after_s over a running belt
  // is taken off as stuck (a plant-side loss, as in the fast plant).
  float stuck_after_s = 10.0F;
  float stuck_progress_mm = 10.0F;
  // Reject crate: a fillet carried back by the reversing reject belt falls in once its rear is
  // this far upstream of the belt's upstream edge.
  float crate_overhang_mm = 30.0F;
  bool operator==(const DemLossConfig&) const = default;
};

// What puts fillets on the takt belt's upstream end.
enum class DemInfeedSource : std::uint8_t {
  // plant_fast.yaml's model of hopper, bulk belt and leveller: a backlog counted in fillets,
  // no particles; the level sensor reads the backlog as heap height.
  kLevelledLayer,
  // The bulk end as a DEM scene (BulkScene, DemPlantConfig::bulk_end) run beside the line:
  // the controller's bulk belt, hopper opening and leveller commands drive it, the level
  // sensor measures its heap in front of the leveller, and each fillet that reaches the stop
  // plate at its discharge edge moves onto the takt belt when there is room.
  kDemBulkEnd,
};

struct DemFeederConfig {
  float spawn_lift_mm = 2.0F;  // a new fillet is placed this high over the takt belt
  DemInfeedSource source = DemInfeedSource::kLevelledLayer;
  // kDemBulkEnd: the level sensor's window along the bulk scene's travel (its x, millimetres
  // from the gate), in front of the leveller; it reads the highest fillet sphere there.
  float level_sensor_from_mm = 250.0F;
  float level_sensor_to_mm = 330.0F;
  // kDemBulkEnd: a fillet at the stop plate moves onto the takt belt once the last fillet
  // there has left this much room behind it (the transfer's own spacing).
  float handover_gap_mm = 20.0F;
  // kDemBulkEnd: the leveller motor's overload trip. The rotor's load torque (the engine's
  // reaction on the rotor wall, mean over a control step) above this trips it: the rotor runs
  // down and the input image says overload until the leveller is commanded off (the motor
  // protection's reset). 29 N m is a 0.37 kW gear motor's rated torque at 120 rpm (P / omega).
  float leveller_trip_torque_nm = 29.0F;
  bool operator==(const DemFeederConfig&) const = default;
};

struct DemPlantConfig {
  DemSimulationConfig simulation;
  DemMachineryConfig machinery;
  DemLossConfig losses;
  DemFeederConfig feeder;
  // config/plant_fast.yaml: cameras, infeed (hopper, leveller, levelled layer), fillet pair
  // probability, drive delay, flip misflip throw, centring and air-knife windows.
  FastPlantConfig shared;
  // config/dem.yaml: materials, types (fillet_a, fillet_b, equipment) and laws; the plant
  // sets timestep, domain, skin, threads and walls.
  dem::ModelSpec engine;
  // config/bulk_line.yaml: the bulk end as a DEM scene, for DemInfeedSource::kDemBulkEnd (its
  // hold_at_discharge is set by the plant). Loaded and checked whichever source is chosen.
  BulkDemConfig bulk_end;
};

// Defaults: the structs' defaults, the fast plant's defaults and the thesis' appendix B model.
DemPlantConfig default_dem_plant_config();

// Reads config/plant_dem.yaml strictly, and the two files it names (relative to its folder).
// Throws ConfigError listing every problem with file, key and line.
DemPlantConfig load_dem_plant_config(const std::filesystem::path& file);

}  // namespace fl
