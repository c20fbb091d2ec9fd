// demlab's commands (commands.hpp): run a model test, write CSV, SVG and the summary.
#include "commands.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>

#include "fl/report/csv.hpp"
#include "fl/report/svg_plot.hpp"

namespace fl::demlab {
namespace {

using model_tests::Stiffness;
using report::CsvCell;
using report::CsvTable;
using report::HeatMap;
using report::Plot;
using report::ReferenceLine;
using report::Series;
using report::SeriesStyle;

constexpr double kDeg = 180.0 / std::numbers::pi;

std::string fmt(double value, int digits = 3) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

CsvCell cell(const std::optional<double>& value) { return value ? CsvCell{*value} : CsvCell{}; }

// Logs every tenth of a sweep.
model_tests::Progress progress(const std::string& name) {
  return [name, last = std::size_t{0}](std::size_t done, std::size_t total) mutable {
    const std::size_t tenth = done * 10 / std::max<std::size_t>(total, 1);
    if (tenth != last || done == total) {
      last = tenth;
      spdlog::info("{}: {}/{} runs", name, done, total);
    }
  };
}

Summary finish(const Context& context, const std::string& name, std::vector<std::string> lines) {
  Summary summary{name, std::move(lines)};
  std::ofstream md(context.out_dir / (name + ".md"));
  md << "# demlab " << name << "\n\n`" << context.command_line << "`\n\n";
  for (const auto& line : summary.lines) md << "- " << line << "\n";
  if (!md) throw std::runtime_error("cannot write " + (context.out_dir / (name + ".md")).string());
  return summary;
}

std::filesystem::path out(const Context& context, const std::string& file) {
  return context.out_dir / file;
}

std::string stiffness_label(const Stiffness& s) {
  return "Sn " + fmt(s.normal_n_per_m3, 2) + ", St " + fmt(s.shear_n_per_m3, 2);
}

}  // namespace

// ------------------------------------------------------------------------------------ settle

Summary run_settle(const Context& context) {
  const auto& c = context.config;
  model_tests::SettleParams fillet = c.settle;
  fillet.common.thread_count = context.threads;
  const model_tests::SettleResult drop = model_tests::run_settle(fillet);
  // Potential energy shown relative to the final rest position, so all parts fall to ~0.
  const double rest_potential = drop.series.back().gravitational_j;
  CsvTable table({"time_s", "kinetic_j", "potential_above_rest_j", "bond_elastic_j",
                  "contact_elastic_j", "total_above_rest_j", "intact_bonds_share"});
  Plot plot;
  plot.title = "Settle test: fillet dropped from " + fmt(fillet.drop_height_m) + " m";
  plot.x.label = "time (s)";
  plot.y.label = "energy (J)";
  Series kinetic{"kinetic", {}, {}, SeriesStyle::kLine, ""};
  Series potential{"potential above rest", {}, {}, SeriesStyle::kLine, ""};
  Series bond{"bond elastic", {}, {}, SeriesStyle::kLine, ""};
  Series total{"total above rest", {}, {}, SeriesStyle::kLine, ""};
  for (const auto& s : drop.series) {
    const double pot = s.gravitational_j - rest_potential;
    table.add_row({s.time_s, s.kinetic_j, pot, s.bond_elastic_j, s.contact_elastic_j,
                   s.total_j - rest_potential, s.intact_bond_share});
    for (auto* series : {&kinetic, &potential, &bond, &total}) series->x.push_back(s.time_s);
    kinetic.y.push_back(s.kinetic_j);
    potential.y.push_back(pot);
    bond.y.push_back(s.bond_elastic_j);
    total.y.push_back(s.total_j - rest_potential);
  }
  plot.series = {kinetic, potential, bond, total};
  plot.references.push_back({true, drop.impact_time_s, "impact"});
  table.write(out(context, "settle.csv"));
  report::write_svg(plot, out(context, "settle.svg"));

  // Figure 3.10 / 4.2: the 8-sphere meta-particle with and without tangential stiffness.
  const Stiffness base = model_tests::spec_stiffness(model_tests::make_spec(fillet.common));
  CsvTable cube_table({"case", "time_s", "kinetic_j", "total_j", "intact_bonds_share"});
  Plot cube_plot;
  cube_plot.title = "Basic meta-particle (8 spheres): with and without shear stiffness";
  cube_plot.x.label = "time (s)";
  cube_plot.y.label = "energy (J)";
  std::vector<std::string> cube_lines;
  for (const bool with_shear : {true, false}) {
    model_tests::SettleParams p = c.settle;
    p.body = model_tests::SettleBody::kBasicCube;
    p.drop_height_m = c.basic_drop_height_m;
    p.duration_s = c.basic_duration_s;
    p.common.stiffness = Stiffness{
        base.normal_n_per_m3, with_shear ? base.shear_n_per_m3 : c.no_shear_stiffness_n_per_m3};
    const auto r = model_tests::run_settle(p);
    const std::string name = with_shear ? "with shear stiffness" : "without shear stiffness";
    Series k{name + ": kinetic", {}, {}, SeriesStyle::kLine, ""};
    Series t{name + ": total", {}, {}, SeriesStyle::kLine, ""};
    for (const auto& s : r.series) {
      cube_table.add_row({name, s.time_s, s.kinetic_j, s.total_j, s.intact_bond_share});
      k.x.push_back(s.time_s);
      t.x.push_back(s.time_s);
      k.y.push_back(s.kinetic_j);
      t.y.push_back(s.total_j);
    }
    cube_plot.series.push_back(k);
    cube_plot.series.push_back(t);
    cube_lines.push_back("cube " + name + ": kinetic 95% gone after " +
                         (r.settle_95_s ? fmt(*r.settle_95_s) + " s" : std::string("never")) +
                         ", total energy gain after impact " + fmt(r.energy_gain_j) +
                         " J, intact bonds " + fmt(100.0 * r.intact_bond_share) + "%");
  }
  cube_table.write(out(context, "settle_cube.csv"));
  report::write_svg(cube_plot, out(context, "settle_cube.svg"));

  // Restitution sweep.
  CsvTable e_table({"restitution", "settle_90_s", "settle_95_s", "settle_99_s"});
  Plot e_plot;
  e_plot.title =
      "Settle time against restitution (fillet, " + fmt(fillet.drop_height_m) + " m drop)";
  e_plot.x = {"coefficient of restitution (-)", true, std::nullopt, std::nullopt};
  e_plot.y.label = "time after impact (s)";
  std::vector<Series> e_series = {{"90% dampened", {}, {}, SeriesStyle::kLineAndMarkers, ""},
                                  {"95% dampened", {}, {}, SeriesStyle::kLineAndMarkers, ""},
                                  {"99% dampened", {}, {}, SeriesStyle::kLineAndMarkers, ""}};
  std::vector<model_tests::SettleResult> sweep(c.restitution_sweep.size());
  model_tests::parallel_for(sweep.size(), context.threads, [&](std::size_t k) {
    model_tests::SettleParams p = c.settle;
    p.common.thread_count = 1;
    p.restitution = c.restitution_sweep[k];
    sweep[k] = model_tests::run_settle(p);
  });
  for (std::size_t k = 0; k < sweep.size(); ++k) {
    const auto& r = sweep[k];
    e_table.add_row(
        {c.restitution_sweep[k], cell(r.settle_90_s), cell(r.settle_95_s), cell(r.settle_99_s)});
    const std::array<std::optional<double>, 3> t = {r.settle_90_s, r.settle_95_s, r.settle_99_s};
    for (std::size_t j = 0; j < 3; ++j) {
      if (!t[j]) continue;
      e_series[j].x.push_back(c.restitution_sweep[k]);
      e_series[j].y.push_back(*t[j]);
    }
  }
  for (auto& s : e_series) {
    if (!s.x.empty()) e_plot.series.push_back(s);
  }
  e_table.write(out(context, "settle_restitution.csv"));
  if (!e_plot.series.empty()) report::write_svg(e_plot, out(context, "settle_restitution.svg"));

  std::vector<std::string> lines = {
      "fillet (" + std::to_string(drop.particles) + " spheres, " + std::to_string(drop.bonds) +
          " bonds, dt " + fmt(drop.timestep_s) + " s) dropped " + fmt(fillet.drop_height_m) +
          " m: 90/95/99% of the impact energy dampened after " +
          (drop.settle_90_s ? fmt(*drop.settle_90_s) : "-") + " / " +
          (drop.settle_95_s ? fmt(*drop.settle_95_s) : "-") + " / " +
          (drop.settle_99_s ? fmt(*drop.settle_99_s) : "-") + " s; intact bonds " +
          fmt(100.0 * drop.intact_bond_share) + "%",
      "thesis figure 4.3: settle times of the order of 0.1-1 s, fastest for balanced and low "
      "stiffness; 99% up to 5x longer when unbalanced (paper fig. 8)"};
  lines.insert(lines.end(), cube_lines.begin(), cube_lines.end());
  lines.push_back(
      "thesis 4.1.2: without tangential stiffness kinetic and potential energy damp "
      "faster but the total energy spirals up and the meta-particle explodes");
  if (!sweep.empty() && sweep.front().settle_95_s && sweep.back().settle_95_s) {
    lines.push_back("restitution " + fmt(c.restitution_sweep.front()) + " -> " +
                    fmt(c.restitution_sweep.back()) + ": 95% settle time " +
                    fmt(*sweep.front().settle_95_s) + " -> " + fmt(*sweep.back().settle_95_s) +
                    " s");
  }
  return finish(context, "settle", lines);
}

// -------------------------------------------------------------------------------------- bend

Summary run_bend(const Context& context) {
  const auto& c = context.config;
  model_tests::BendParams params = c.bend;
  params.common.thread_count = context.threads;
  const model_tests::BendResult nominal = model_tests::run_bend(params);
  // The thesis' own run has no damping: its swing, beside the rest angle, shows what the
  // thesis' figure read off a moving fillet.
  std::optional<model_tests::BendResult> undamped;
  if (params.rest_damping_per_s > 0.0) {
    model_tests::BendParams thesis_run = params;
    thesis_run.rest_damping_per_s = 0.0;
    undamped = model_tests::run_bend(thesis_run);
  }
  const Stiffness base = model_tests::spec_stiffness(model_tests::make_spec(params.common));

  std::vector<model_tests::BendResult> sweep(c.bend_stiffness_factors.size());
  model_tests::parallel_for(
      sweep.size(), context.threads,
      [&](std::size_t k) {
        model_tests::BendParams p = c.bend;
        p.common.thread_count = 1;
        const double f = c.bend_stiffness_factors[k];
        p.common.stiffness = Stiffness{f * base.normal_n_per_m3, f * base.shear_n_per_m3};
        sweep[k] = model_tests::run_bend(p);
      },
      progress("bend"));
  CsvTable table({"stiffness_factor", "normal_stiffness_n_per_m3", "shear_stiffness_n_per_m3",
                  "bend_angle_deg", "bend_angle_min_deg", "bend_angle_max_deg",
                  "intact_bonds_share"});
  Series mean{"bend angle (mean, last quarter)", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  Series low{"min", {}, {}, SeriesStyle::kScatter, "#999999"};
  Series high{"max", {}, {}, SeriesStyle::kScatter, "#555555"};
  for (std::size_t k = 0; k < sweep.size(); ++k) {
    const double f = c.bend_stiffness_factors[k];
    const auto& r = sweep[k];
    table.add_row({f, f * base.normal_n_per_m3, f * base.shear_n_per_m3, r.angle_deg,
                   r.angle_min_deg, r.angle_max_deg, r.intact_bond_share});
    if (!std::isfinite(r.angle_deg)) continue;
    mean.x.push_back(f);
    mean.y.push_back(r.angle_deg);
    low.x.push_back(f);
    low.y.push_back(r.angle_min_deg);
    high.x.push_back(f);
    high.y.push_back(r.angle_max_deg);
  }
  table.write(out(context, "bend.csv"));
  CsvTable series({"time_s", "bend_angle_deg", "tip_x_m", "tip_z_m"});
  for (const auto& s : nominal.series) {
    series.add_row({s.time_s, s.angle_deg, s.tip_x_m, s.tip_z_m});
  }
  series.write(out(context, "bend_series.csv"));
  Plot plot;
  plot.title =
      "Bend test: angle against bond stiffness (x appendix B " + stiffness_label(base) + ")";
  plot.x = {"stiffness factor (both Sn and St) (-)", true, std::nullopt, std::nullopt};
  plot.y.label = "bend angle (deg)";
  plot.series = {mean, low, high};
  plot.references.push_back({false, 130.0, "real fillet (thesis 4.1.3)"});
  plot.references.push_back({true, 1.0, "appendix B"});
  report::write_svg(plot, out(context, "bend.svg"));
  std::vector<std::string> lines;
  if (undamped) {
    lines.push_back("appendix B stiffness: bend angle " + fmt(nominal.angle_deg) +
                    " deg at rest (rest damping " + fmt(params.rest_damping_per_s) + "/s; range " +
                    fmt(nominal.angle_min_deg) + " to " + fmt(nominal.angle_max_deg) +
                    " deg over the last quarter)");
    lines.push_back("undamped, as the thesis' run: mean " + fmt(undamped->angle_deg) +
                    " deg, swinging from " + fmt(undamped->angle_min_deg) + " to " +
                    fmt(undamped->angle_max_deg) + " deg over the last quarter");
  } else {
    lines.push_back("appendix B stiffness: bend angle " + fmt(nominal.angle_deg) + " deg (range " +
                    fmt(nominal.angle_min_deg) + " to " + fmt(nominal.angle_max_deg) +
                    " deg over the last quarter: the bonds have no damping)");
  }
  lines.insert(lines.end(),
               {"stiffness x" + fmt(c.bend_stiffness_factors.front()) + " -> x" +
                    fmt(c.bend_stiffness_factors.back()) + ": " + fmt(sweep.front().angle_deg) +
                    " -> " + fmt(sweep.back().angle_deg) + " deg",
                "thesis 4.1.3: real fillet ~130 deg; higher stiffness -> lower angle; very low "
                "stiffness needed for 130 deg"});
  return finish(context, "bend", lines);
}

// ------------------------------------------------------------------------------------- slide

Summary run_slide(const Context& context) {
  const auto& c = context.config;
  struct Case {
    bool rigid;
    double mu;
    double surface_energy;
    std::optional<double> angle;
  };
  // A model without adhesion (no jkr between fillet and plate) slides at zero surface energy,
  // and has no surface energy to sweep.
  const dem::ModelSpec& base = c.slide.common.base_spec;
  const std::uint32_t equipment = model_tests::equipment_type(base);
  const bool has_adhesion = model_tests::has_fillet_contact_law(base, "jkr", equipment);
  if (!has_adhesion) {
    spdlog::warn(
        "slide: the DEM config's fillet-equipment contact laws have no jkr: every case "
        "slides at zero surface energy and the surface energy sweep is left out");
  }
  const double surface_energy = has_adhesion ? c.slide.surface_energy_j_per_m2 : 0.0;
  std::vector<Case> cases;
  for (const double mu : c.friction_sweep) {
    cases.push_back({false, mu, surface_energy, {}});
    if (has_adhesion) cases.push_back({true, mu, surface_energy, {}});
    cases.push_back({true, mu, 0.0, {}});
  }
  if (has_adhesion) {
    for (const double w : c.surface_energy_sweep_j_per_m2) {
      cases.push_back({false, c.slide.friction_coefficient, w, {}});
    }
  }
  model_tests::parallel_for(
      cases.size(), context.threads,
      [&](std::size_t k) {
        model_tests::SlideParams p = c.slide;
        p.common.thread_count = 1;
        p.rigid = cases[k].rigid;
        p.friction_coefficient = cases[k].mu;
        p.surface_energy_j_per_m2 = cases[k].surface_energy;
        cases[k].angle = model_tests::run_slide(p).slide_angle_deg;
      },
      progress("slide"));
  CsvTable table({"model", "friction_coefficient", "surface_energy_j_per_m2", "slide_angle_deg",
                  "arctan_mu_deg"});
  Series flexible{
      "flexible, w = " + fmt(surface_energy) + " J/m^2", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  Series rigid{"solid, w = " + fmt(c.slide.surface_energy_j_per_m2) + " J/m^2",
               {},
               {},
               SeriesStyle::kLineAndMarkers,
               ""};
  Series rigid_dry{"solid, no adhesion", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  Series coulomb{"atan(mu)", {}, {}, SeriesStyle::kLine, "#999999"};
  Series adhesion{"flexible, mu = " + fmt(c.slide.friction_coefficient),
                  {},
                  {},
                  SeriesStyle::kLineAndMarkers,
                  ""};
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Case& x = cases[k];
    const bool energy_sweep = k >= 3 * c.friction_sweep.size();
    table.add_row({std::string(x.rigid ? "solid" : "flexible"), x.mu, x.surface_energy,
                   cell(x.angle), std::atan(x.mu) * kDeg});
    if (!x.angle) continue;
    Series* target = energy_sweep             ? &adhesion
                     : !x.rigid               ? &flexible
                     : x.surface_energy > 0.0 ? &rigid
                                              : &rigid_dry;
    target->x.push_back(energy_sweep ? x.surface_energy : x.mu);
    target->y.push_back(*x.angle);
  }
  for (const double mu : c.friction_sweep) {
    if (std::atan(mu) * kDeg > c.slide.max_angle_deg) continue;
    coulomb.x.push_back(mu);
    coulomb.y.push_back(std::atan(mu) * kDeg);
  }
  table.write(out(context, "slide.csv"));
  Plot plot;
  plot.title = "Slide test: slide angle against friction coefficient";
  // With static_kinetic_friction in the fillet-steel chain the swept mu is the static one
  // (the onset, so atan(mu) stays the reference), mu_k following at its configured ratio.
  const bool static_kinetic =
      model_tests::has_fillet_contact_law(base, "static_kinetic_friction", equipment);
  plot.x.label = static_kinetic
                     ? "static friction coefficient mu_s fillet-steel (mu_k at the configured "
                       "mu_k / mu_s) (-)"
                     : "friction coefficient fillet-steel (-)";
  plot.y.label = "slide angle (deg)";
  for (auto* s : {&flexible, &rigid, &rigid_dry, &coulomb}) {
    if (!s->x.empty()) plot.series.push_back(*s);
  }
  report::write_svg(plot, out(context, "slide.svg"));
  if (!adhesion.x.empty()) {
    Plot p2;
    p2.title = "Slide test: slide angle against interfacial surface energy";
    p2.x.label = "surface energy fillet-steel (J/m^2)";
    p2.y.label = "slide angle (deg)";
    p2.series = {adhesion};
    report::write_svg(p2, out(context, "slide_adhesion.svg"));
  }
  auto angle_at = [&](const Series& s, double x) -> std::string {
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      if (std::abs(s.x[k] - x) < 1e-12) return fmt(s.y[k]) + " deg";
    }
    return "no slide";
  };
  std::vector<std::string> lines = {
      has_adhesion
          ? "mu 0.5: flexible " + angle_at(flexible, 0.5) + ", solid " + angle_at(rigid, 0.5) +
                ", solid without adhesion " + angle_at(rigid_dry, 0.5) + " (atan 0.5 = 26.6 deg)"
          : "mu 0.5, the model without adhesion: flexible " + angle_at(flexible, 0.5) + ", solid " +
                angle_at(rigid_dry, 0.5) + " (atan 0.5 = 26.6 deg)"};
  if (adhesion.x.size() >= 2) {
    lines.push_back("surface energy " + fmt(adhesion.x.front()) + " -> " + fmt(adhesion.x.back()) +
                    " J/m^2 at mu " + fmt(c.slide.friction_coefficient) + ": " +
                    fmt(adhesion.y.front()) + " -> " + fmt(adhesion.y.back()) + " deg");
  }
  lines.push_back(
      "thesis 4.1.4: angle rises ~linearly with mu, surface energy has no effect, "
      "solid fillet slides at higher angles than flexible ones; mu 0.5 matches the "
      "real fillet");
  return finish(context, "slide", lines);
}

// ---------------------------------------------------------------------------------- compress

Summary run_compress(const Context& context) {
  model_tests::CompressParams params = context.config.compress;
  params.common.thread_count = context.threads;
  const model_tests::CompressResult r = model_tests::run_compress(params);
  CsvTable table({"time_s", "plate_travel_m", "block_shortening_m", "strain", "stress_pa",
                  "section_force_n", "plate_force_n"});
  Series measured{"bond section stress", {}, {}, SeriesStyle::kLine, ""};
  Series plate{"plate stress vs plate strain", {}, {}, SeriesStyle::kLine, ""};
  Series analytic{"analytic pi Sn r / 2", {}, {}, SeriesStyle::kLine, "#999999"};
  const double height = params.block_nz * 2.0 * params.common.sub_particle_radius_m;
  for (const auto& s : r.series) {
    const double strain = s.block_shortening_m / r.gauge_length_m;
    const double stress = s.section_force_n / r.area_m2;
    table.add_row({s.time_s, s.plate_travel_m, s.block_shortening_m, strain, stress,
                   s.section_force_n, s.plate_force_n});
    measured.x.push_back(strain);
    measured.y.push_back(stress);
    plate.x.push_back(s.plate_travel_m / height);
    plate.y.push_back(s.plate_force_n / r.area_m2);
    analytic.x.push_back(strain);
    analytic.y.push_back(strain * r.analytic_youngs_modulus_pa);
  }
  table.write(out(context, "compress.csv"));
  Plot plot;
  plot.title = "Compression test: bonded block " + std::to_string(params.block_nx) + "x" +
               std::to_string(params.block_ny) + "x" + std::to_string(params.block_nz) +
               ", r = " + fmt(params.common.sub_particle_radius_m * 1e3) + " mm";
  plot.x.label = "strain (-)";
  plot.y.label = "stress (Pa)";
  plot.series = {measured, plate, analytic};
  report::write_svg(plot, out(context, "compress.svg"));
  return finish(
      context, "compress",
      {"E = F L / (A dL) = " + fmt(r.youngs_modulus_pa / 1e3, 5) +
           " kPa (analytic pi Sn r/2 = " + fmt(r.analytic_youngs_modulus_pa / 1e3, 5) +
           " kPa); through the plates " + fmt(r.plate_youngs_modulus_pa / 1e3, 5) + " kPa",
       "thesis 4.3: real block 48.4 kPa (visco-elastic, plastic); model input E = 370 kPa "
       "(Ko et al.), which in this engine sets only the Hertz contacts",
       "Sn giving 48.4 kPa at this radius: " +
           fmt(48.4e3 / (std::numbers::pi * params.common.sub_particle_radius_m / 2.0), 3) +
           " N/m^3"});
}

// ------------------------------------------------------------------------------------ impact

Summary run_impact(const Context& context) {
  const auto& c = context.config;
  model_tests::ImpactParams params;
  params.drop = c.impact_drop;
  params.speeds_m_per_s = c.impact_speeds_m_per_s;
  params.stiffness_sets = c.impact_stiffness_sets;
  params.orientations = c.impact_orientations;
  params.threads = context.threads;
  params.progress = progress("impact");
  const auto rows = model_tests::run_impact(params);
  CsvTable table({"normal_stiffness_n_per_m3", "shear_stiffness_n_per_m3", "speed_mps",
                  "orientation", "intact_bonds_percent"});
  Plot plot;
  plot.title = "Impact speed stability (mean over " + std::to_string(c.impact_orientations) +
               " orientations)";
  plot.x.label = "impact speed (m/s)";
  plot.y = {"intact bonds (%)", false, 0.0, 100.5};
  std::vector<std::string> lines;
  for (const Stiffness& s : c.impact_stiffness_sets) {
    Series series{stiffness_label(s), {}, {}, SeriesStyle::kLineAndMarkers, ""};
    for (const double v : c.impact_speeds_m_per_s) {
      double sum = 0.0;
      int n = 0;
      for (const auto& row : rows) {
        if (row.stiffness.normal_n_per_m3 == s.normal_n_per_m3 &&
            row.stiffness.shear_n_per_m3 == s.shear_n_per_m3 && row.speed_m_per_s == v) {
          sum += 100.0 * row.intact_bond_share;
          ++n;
        }
      }
      series.x.push_back(v);
      series.y.push_back(sum / std::max(n, 1));
    }
    lines.push_back(stiffness_label(s) + ": intact bonds " + fmt(series.y.front()) + "% at " +
                    fmt(series.x.front()) + " m/s, " + fmt(series.y.back()) + "% at " +
                    fmt(series.x.back()) + " m/s");
    plot.series.push_back(series);
  }
  for (const auto& row : rows) {
    table.add_row({row.stiffness.normal_n_per_m3, row.stiffness.shear_n_per_m3, row.speed_m_per_s,
                   static_cast<double>(row.orientation), 100.0 * row.intact_bond_share});
  }
  table.write(out(context, "impact.csv"));
  report::write_svg(plot, out(context, "impact.svg"));
  lines.push_back(
      "thesis 4.2.1: faster impacts break more bonds; configurations stable at low "
      "speed can fail at high speed; unstable at high Sn with low St");
  return finish(context, "impact", lines);
}

// -------------------------------------------------------------------------------------- drop

Summary run_drop(const Context& context) {
  const auto& c = context.config;
  model_tests::AngleParams params;
  params.drop = c.angle_drop;
  params.samples = c.angle_samples;
  params.threads = context.threads;
  params.progress = progress("drop");
  const auto rows = model_tests::run_angle_drop(params);
  CsvTable table({"yaw_rad", "pitch_rad", "roll_rad", "intact_bonds_percent"});
  Series high{">= 95% intact", {}, {}, SeriesStyle::kScatter, "#009E73"};
  Series mid{"75-95% intact", {}, {}, SeriesStyle::kScatter, "#E69F00"};
  Series low{"< 75% intact", {}, {}, SeriesStyle::kScatter, "#D55E00"};
  double sum = 0.0, worst = 100.0;
  std::size_t below95 = 0;
  for (const auto& row : rows) {
    const double percent = 100.0 * row.intact_bond_share;
    table.add_row({row.yaw_rad, row.pitch_rad, row.roll_rad, percent});
    Series& target = percent >= 95.0 ? high : percent >= 75.0 ? mid : low;
    target.x.push_back(row.pitch_rad * kDeg);
    target.y.push_back(row.roll_rad * kDeg);
    sum += percent;
    worst = std::min(worst, percent);
    below95 += percent < 95.0 ? 1U : 0U;
  }
  table.write(out(context, "drop.csv"));
  Plot plot;
  plot.title = "Drop angle stability at " + fmt(c.angle_drop.speed_m_per_s) + " m/s (" +
               std::to_string(rows.size()) + " Hammersley orientations)";
  plot.x = {"pitch (deg)", false, 0.0, 360.0};
  plot.y = {"roll (deg)", false, 0.0, 360.0};
  for (auto* s : {&high, &mid, &low}) {
    if (!s->x.empty()) plot.series.push_back(*s);
  }
  report::write_svg(plot, out(context, "drop.svg"));
  return finish(context, "drop",
                {"mean intact bonds " +
                     fmt(sum / static_cast<double>(std::max<std::size_t>(rows.size(), 1))) +
                     "%, worst " + fmt(worst) + "%, " + std::to_string(below95) + " of " +
                     std::to_string(rows.size()) + " orientations below 95%",
                 "thesis 4.2.2 (5000 samples, 2 m/s): distinct orientations (landing on the "
                 "tip) lose more bonds"});
}

// ----------------------------------------------------------------------------------- scaling

Summary run_scaling(const Context& context) {
  const auto& c = context.config;
  model_tests::ScalingParams params;
  params.drop = c.scaling_drop;
  params.scales = c.scales;
  params.threads = context.threads;
  params.progress = progress("scaling");
  const auto rows = model_tests::run_scaling(params);
  CsvTable table({"scale", "sub_particle_radius_m", "timestep_s", "bond_critical_step_s",
                  "intact_bonds_percent", "min_intact_bonds_percent", "settle_95_s"});
  Series intact{"intact bonds at end (%)", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  Series settle{"95% settle time (s) x 100", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  for (const auto& row : rows) {
    table.add_row({row.scale, row.scale * c.scaling_drop.common.sub_particle_radius_m,
                   row.result.timestep_s, row.result.bond_critical_step_s,
                   100.0 * row.result.intact_bond_share, 100.0 * row.result.min_intact_bond_share,
                   cell(row.result.settle_95_s)});
    intact.x.push_back(row.scale);
    intact.y.push_back(100.0 * row.result.intact_bond_share);
    if (row.result.settle_95_s) {
      settle.x.push_back(row.scale);
      settle.y.push_back(100.0 * *row.result.settle_95_s);
    }
  }
  table.write(out(context, "scaling.csv"));
  Plot plot;
  plot.title =
      "Scaling stability: fillet scaled, dropped " + fmt(c.scaling_drop.drop_height_m) + " m";
  plot.x = {"scale (-)", true, std::nullopt, std::nullopt};
  plot.y.label = "intact bonds (%) / settle time (s x 100)";
  plot.series = {intact};
  if (!settle.x.empty()) plot.series.push_back(settle);
  report::write_svg(plot, out(context, "scaling.svg"));

  // Timestep stability at scale 1: the integrator's limit (not in the thesis).
  std::vector<model_tests::DropResult> steps(c.timestep_factors.size());
  model_tests::parallel_for(steps.size(), context.threads, [&](std::size_t k) {
    model_tests::DropParams p = c.scaling_drop;
    p.common.thread_count = 1;
    p.timestep_factor_of_bond_critical = c.timestep_factors[k];
    p.duration_s = std::min(p.duration_s, 1.0);
    steps[k] = model_tests::run_drop(p);
  });
  CsvTable step_table({"timestep_over_bond_critical", "timestep_s", "intact_bonds_percent"});
  Series step_series{"intact bonds (%)", {}, {}, SeriesStyle::kLineAndMarkers, ""};
  for (std::size_t k = 0; k < steps.size(); ++k) {
    step_table.add_row(
        {c.timestep_factors[k], steps[k].timestep_s, 100.0 * steps[k].intact_bond_share});
    step_series.x.push_back(c.timestep_factors[k]);
    step_series.y.push_back(100.0 * steps[k].intact_bond_share);
  }
  step_table.write(out(context, "scaling_timestep.csv"));
  Plot step_plot;
  step_plot.title =
      "Timestep stability (scale 1, " + fmt(c.scaling_drop.drop_height_m) + " m drop)";
  step_plot.x = {"timestep / bond critical step 2/omega (-)", true, std::nullopt, std::nullopt};
  step_plot.y = {"intact bonds (%)", false, 0.0, 100.5};
  step_plot.series = {step_series};
  step_plot.references.push_back({true, 1.0, "critical step"});
  report::write_svg(step_plot, out(context, "scaling_timestep.svg"));

  std::string first_full = "never";
  for (const auto& row : rows) {
    if (row.result.intact_bond_share >= 0.999) {
      first_full = fmt(row.scale);
      break;
    }
  }
  std::string first_broken = "none";
  for (std::size_t k = 0; k < steps.size(); ++k) {
    if (steps[k].intact_bond_share < 0.999) {
      first_broken = fmt(c.timestep_factors[k]) + " x critical";
      break;
    }
  }
  return finish(
      context, "scaling",
      {"intact bonds at scale " + fmt(rows.front().scale) + ": " +
           fmt(100.0 * rows.front().result.intact_bond_share) + "%, at scale " +
           fmt(rows.back().scale) + ": " + fmt(100.0 * rows.back().result.intact_bond_share) +
           "%; all intact from scale " + first_full,
       "timestep sweep: bonds first break at " + first_broken,
       "thesis 4.2.3: unstable at 0.25x, stability rises with scale; damping time grows "
       "with scale"});
}

// --------------------------------------------------------------------------------------- doe

Summary run_doe(const Context& context) {
  const auto& c = context.config;
  model_tests::DoeParams params;
  params.settle = c.settle;
  params.settle.duration_s = c.doe_duration_s;
  if (c.doe_bend) {
    params.bend = c.bend;
    params.bend->duration_s = c.doe_bend_duration_s;
  }
  params.normal_levels_n_per_m3 = c.doe_normal_levels_n_per_m3;
  params.shear_levels_n_per_m3 = c.doe_shear_levels_n_per_m3;
  params.threads = context.threads;
  params.progress = progress("doe");
  const auto rows = model_tests::run_doe(params);
  CsvTable table({"normal_stiffness_n_per_m3", "shear_stiffness_n_per_m3", "timestep_s",
                  "intact_bonds_percent", "settle_90_s", "settle_95_s", "settle_99_s",
                  "energy_gain_j", "bend_angle_deg"});
  const std::size_t columns = params.shear_levels_n_per_m3.size();
  const std::size_t rows_n = params.normal_levels_n_per_m3.size();
  HeatMap intact, settle, bend;
  for (HeatMap* m : {&intact, &settle, &bend}) {
    m->x = {"shear stiffness St (N/m^3)", true, std::nullopt, std::nullopt};
    m->y = {"normal stiffness Sn (N/m^3)", true, std::nullopt, std::nullopt};
    m->x_centers = params.shear_levels_n_per_m3;
    m->y_centers = params.normal_levels_n_per_m3;
    m->values.assign(columns * rows_n, std::nullopt);
  }
  intact.title = "DOE: intact bonds after a " + fmt(c.settle.drop_height_m) + " m drop";
  intact.value_label = "intact bonds (%)";
  settle.title = "DOE: time to dampen 99% (empty: unstable or not settled)";
  settle.value_label = "settle 99% (s)";
  bend.title = "DOE: bend angle (empty: bonds broke)";
  bend.value_label = "bend angle (deg)";
  std::size_t stable = 0;
  double best_settle = 1e9;
  Stiffness best{};
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& row = rows[k];
    const double percent = 100.0 * row.settle.intact_bond_share;
    const bool ok = percent >= 95.0;  // the "stable" threshold of our figures
    std::optional<double> angle;
    if (row.bend && row.bend->intact_bond_share >= 0.95 && std::isfinite(row.bend->angle_deg)) {
      angle = row.bend->angle_deg;
    }
    table.add_row({row.stiffness.normal_n_per_m3, row.stiffness.shear_n_per_m3,
                   row.settle.timestep_s, percent, cell(row.settle.settle_90_s),
                   cell(row.settle.settle_95_s), cell(row.settle.settle_99_s),
                   row.settle.energy_gain_j, cell(angle)});
    intact.values[k] = percent;
    if (ok && row.settle.settle_99_s) {
      settle.values[k] = *row.settle.settle_99_s;
      if (*row.settle.settle_99_s < best_settle) {
        best_settle = *row.settle.settle_99_s;
        best = row.stiffness;
      }
    }
    bend.values[k] = angle;
    stable += ok ? 1U : 0U;
  }
  table.write(out(context, "doe.csv"));
  intact.value_min = 0.0;
  intact.value_max = 100.0;
  report::write_svg(intact, out(context, "doe.svg"));
  report::write_svg(settle, out(context, "doe_settle.svg"));
  if (params.bend) report::write_svg(bend, out(context, "doe_bend.svg"));
  // The thesis' unstable corner: Sn >> St. Compare intact bonds for Sn/St >= 100 and <= 10.
  double unbalanced = 0.0, balanced = 0.0;
  int n_unbalanced = 0, n_balanced = 0;
  for (const auto& row : rows) {
    const double ratio = row.stiffness.normal_n_per_m3 / row.stiffness.shear_n_per_m3;
    if (ratio >= 100.0) {
      unbalanced += row.settle.intact_bond_share;
      ++n_unbalanced;
    } else if (ratio <= 10.0) {
      balanced += row.settle.intact_bond_share;
      ++n_balanced;
    }
  }
  std::vector<std::string> lines = {
      std::to_string(stable) + " of " + std::to_string(rows.size()) +
          " grid points keep >= 95% of their bonds",
      "mean intact bonds: Sn/St >= 100: " + fmt(100.0 * unbalanced / std::max(n_unbalanced, 1)) +
          "%, Sn/St <= 10: " + fmt(100.0 * balanced / std::max(n_balanced, 1)) + "%",
      "fastest 99% settle " + fmt(best_settle) + " s at " + stiffness_label(best),
      "thesis 4.1.2-4.1.3: unstable region at high Sn and low St (figure 4.4), settle fastest "
      "for balanced, low stiffness (valley, figure 4.3)"};
  return finish(context, "doe", lines);
}

}  // namespace fl::demlab
