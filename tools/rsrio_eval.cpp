// rsrio-eval: APE and RPE of an estimate against ground truth, as evo computes them, and a plot.
#include <cstdio>
#include <iostream>

#include "rsrio/common/cli.hpp"
#include "rsrio/eval/plot.hpp"
#include "rsrio/eval/trajectory.hpp"

namespace {
void print_stats(const char* name, const rsrio::eval::ErrorStats& s) {
  std::printf("%-26s rmse %9.4f  mean %9.4f  median %9.4f  std %9.4f  min %9.4f  max %9.4f\n", name, s.rmse, s.mean,
              s.median, s.std, s.min, s.max);
}
}  // namespace

int main(int argc, char** argv) {
  std::string gt, est, align = "se3", plot, delta = "1.0", max_dt = "0.01";
  rsrio::Cli cli("rsrio-eval", "Absolute and relative pose error of an estimate against ground truth (TUM files),\n"
                               "computed as evo_ape / evo_rpe do, with an optional trajectory plot.");
  cli.option("--gt", "GT.tum", "ground truth trajectory (TUM: t x y z qx qy qz qw)", &gt)
      .option("--est", "EST.tum", "estimated trajectory (TUM)", &est)
      .option("--align", "se3|se2|none", "Umeyama alignment before APE (default se3; se2 = yaw + translation)", &align)
      .option("--plot", "OUT.png", "write estimate and ground truth seen from above", &plot)
      .option("--delta", "M", "RPE pose-pair distance along the ground truth in metres (default 1)", &delta)
      .option("--max-dt", "S", "largest time difference when pairing stamps (default 0.01 s, as evo)", &max_dt);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (gt.empty() || est.empty()) {
    std::cerr << "rsrio-eval: --gt and --est are required\n(see rsrio-eval --help)\n";
    return rsrio::kExitUsage;
  }
  try {
    const auto alignment = rsrio::eval::parse_alignment(align);
    const double d = std::stod(delta), dt = std::stod(max_dt);
    const auto ref = rsrio::eval::read_tum(gt), e = rsrio::eval::read_tum(est);
    rsrio::eval::Trajectory ra, ea;
    rsrio::eval::associate(ref, e, dt, ra, ea);
    if (ra.size() < 3) {
      std::cerr << "rsrio-eval: only " << ra.size() << " poses pair up within " << dt
                << " s: are both files on the same clock?\n";
      return 1;
    }
    const auto a = rsrio::eval::ape(ra, ea, alignment);
    const auto r = rsrio::eval::rpe(ra, ea, d);
    std::printf("%zu of %zu estimated poses paired with ground truth; path %.2f m; alignment %s\n", ra.size(), e.size(),
                a.path_length_m, align.c_str());
    print_stats("APE translation (m)", a.translation_m);
    print_stats("APE rotation (deg)", a.rotation_deg);
    std::printf("%-26s %.2f %% of the path\n", "APE translation rmse", 100.0 * a.translation_m.rmse / a.path_length_m);
    char label[64];
    std::snprintf(label, sizeof label, "RPE translation (m/%gm)", d);
    print_stats(label, r.translation_m);
    std::snprintf(label, sizeof label, "RPE rotation (deg/%gm)", d);
    print_stats(label, r.rotation_deg);
    if (!plot.empty()) {
      const auto aligned = rsrio::eval::transformed(ea, a.alignment);
      rsrio::eval::plot_xy(plot, {{"ground truth", &ra, {60, 60, 60}}, {"estimate (aligned)", &aligned, {40, 40, 220}}},
                           "APE " + std::to_string(a.translation_m.rmse).substr(0, 5) + " m rmse");
      std::printf("plot: %s\n", plot.c_str());
    }
  } catch (const std::exception& ex) {
    std::cerr << "rsrio-eval: error: " << ex.what() << "\n";
    return rsrio::kExitUsage;
  }
  return 0;
}
