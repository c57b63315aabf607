// rsrio-eval: APE and RPE of an estimate against ground truth, as evo computes them, and a plot.
//
//   rsrio-eval --gt GT.tum --est EST.tum [--align se3|se2|none] [--plot OUT.png]
//   rsrio-eval --table | --table-json [--data DIR] [--scenarios DIR] [--sequences 1,2,...] [--config FILE] [--reuse]
//
// --table reproduces the paper's Table II for the five shipped scenarios (scenarios/seq1..seq5):
// it makes each recording with rsrio-sim when DIR/<scenario>.mcap is missing, replays it with
// rsrio-replay (--config FILE is passed on: the pipeline options, default config/rsrio.yaml when
// present), and prints APE (SE(3) Umeyama alignment, one pair per estimated pose) next to the
// paper's MRIO column. rsrio-sim and rsrio-replay are taken from the directory of this program.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "rsrio/common/cli.hpp"
#include "rsrio/eval/plot.hpp"
#include "rsrio/eval/trajectory.hpp"

namespace {
namespace fs = std::filesystem;

// Table I / II of the paper (shared/paper/radarsplat-rio.tex).
struct Sequence {
  const char* scenario;
  const char* name;
  double paper_distance_m;
  double mrio_translation_m, mrio_rotation_deg;
  double paper_ours_translation_m, paper_ours_rotation_deg;
};
constexpr std::array<Sequence, 5> kSequences{{
    {"seq1_meeting_room", "Sequence 1", 42.46, 0.94, 5.03, 0.19, 1.91},
    {"seq2_small_loop", "Sequence 2", 91.89, 7.57, 15.51, 0.42, 2.06},
    {"seq3_large_loop", "Sequence 3", 144.59, 22.48, 32.38, 2.04, 5.25},
    {"seq4_small_large_loop", "Sequence 4", 206.12, 11.04, 17.62, 1.05, 2.66},
    {"seq5_medium_large_loop", "Sequence 5", 233.54, 12.9, 21.55, 0.97, 3.28},
}};

// Runs a program, its output going to `log` (appended); the exit code, or -1 if it could not run.
int run(const std::vector<std::string>& args, const std::string& log) {
  std::cerr << "rsrio-eval: running";
  for (const auto& a : args) std::cerr << ' ' << a;
  std::cerr << " (output: " << log << ")\n";
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    if (!freopen(log.c_str(), "a", stdout) || !freopen(log.c_str(), "a", stderr)) _exit(127);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A number from stats.json (flat key search: the file is ours and simple).
double json_number(const std::string& text, const std::string& key) {
  const auto at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return -1;
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

struct Row {
  const Sequence* seq = nullptr;
  bool ok = false;
  std::string error;
  double distance_m = 0, translation_m = 0, rotation_deg = 0;
  double frames = 0, rejected = 0, damaged = 0, rtf = 0;
  std::size_t pairs = 0;
};

int table(const std::string& data_dir, const std::string& scenario_dir, const std::string& sequences,
          std::string config, bool reuse, bool json) {
  const fs::path bin = fs::read_symlink("/proc/self/exe").parent_path();
  const std::string sim = (bin / "rsrio-sim").string(), replay = (bin / "rsrio-replay").string();
  for (const auto& p : {sim, replay})
    if (!fs::exists(p)) {
      std::cerr << "rsrio-eval: error: " << p << " not found (--table needs rsrio-sim and rsrio-replay next to rsrio-eval; "
                << "build them)\n";
      return 1;
    }
  if (config.empty() && fs::exists("config/rsrio.yaml")) config = "config/rsrio.yaml";
  fs::create_directories(data_dir);
  std::vector<Row> rows;
  for (std::size_t i = 0; i < kSequences.size(); ++i) {
    if (!sequences.empty() && ("," + sequences + ",").find("," + std::to_string(i + 1) + ",") == std::string::npos)
      continue;
    Row row;
    row.seq = &kSequences[i];
    const std::string name = row.seq->scenario;
    const fs::path rec = fs::path(data_dir) / (name + ".mcap");
    const fs::path out = fs::path(data_dir) / (name + "_replay");
    const std::string log = (fs::path(data_dir) / (name + ".log")).string();
    rows.push_back(row);
    Row& r = rows.back();
    if (!fs::exists(rec)) {
      const std::string part = rec.string() + ".part";
      if (run({sim, "--scenario", (fs::path(scenario_dir) / (name + ".yaml")).string(), "--out", part}, log) != 0) {
        r.error = "rsrio-sim failed (see " + log + ")";
        continue;
      }
      fs::rename(part, rec);
    }
    if (!reuse || !fs::exists(out / "frontend.tum")) {
      std::vector<std::string> args{replay, "--quiet", "--input", rec.string(), "--out", out.string()};
      if (!config.empty()) args.insert(args.end(), {"--config", config});
      if (run(args, log) != 0) {
        r.error = "rsrio-replay failed (see " + log + ")";
        continue;
      }
    }
    try {
      const auto gt = rsrio::eval::read_tum((out / "ground_truth.tum").string());
      const auto est = rsrio::eval::read_tum((out / "frontend.tum").string());
      rsrio::eval::Trajectory e, g;
      rsrio::eval::associate(est, gt, 0.01, e, g);  // one pair per estimated pose
      r.pairs = e.size();
      if (e.size() < 3) throw std::runtime_error("fewer than 3 estimated poses pair with the ground truth");
      const auto a = rsrio::eval::ape(g, e, rsrio::eval::Alignment::kSE3);
      r.distance_m = a.path_length_m;
      r.translation_m = a.translation_m.rmse;
      r.rotation_deg = a.rotation_deg.rmse;
      std::ifstream f(out / "stats.json");
      std::stringstream text;
      text << f.rdbuf();
      r.frames = json_number(text.str(), "frames");
      r.rejected = json_number(text.str(), "rejected_frames\": {\"total");
      r.damaged = json_number(text.str(), "damaged_frames\": {\"total");
      r.rtf = json_number(text.str(), "recording_seconds") / std::max(1e-9, json_number(text.str(), "wall_seconds"));
      r.ok = true;
    } catch (const std::exception& ex) {
      r.error = ex.what();
    }
  }
  bool all_ok = true;
  if (json) {
    std::printf("[\n");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      all_ok &= r.ok;
      std::printf("  {\"sequence\": \"%s\", \"scenario\": \"%s\", \"ok\": %s, \"error\": \"%s\", "
                  "\"distance_m\": %.3f, \"paper_distance_m\": %.2f, \"mrio_translation_m\": %.2f, "
                  "\"mrio_rotation_deg\": %.2f, \"frontend_translation_m\": %.4f, \"frontend_rotation_deg\": %.3f, "
                  "\"frontend_percent_of_distance\": %.3f, \"frames\": %.0f, \"rejected_frames\": %.0f, "
                  "\"damaged_frames\": %.0f, \"replay_real_time_factor\": %.2f}%s\n",
                  r.seq->name, r.seq->scenario, r.ok ? "true" : "false", r.error.c_str(), r.distance_m,
                  r.seq->paper_distance_m, r.seq->mrio_translation_m, r.seq->mrio_rotation_deg, r.translation_m,
                  r.rotation_deg, r.distance_m > 0 ? 100 * r.translation_m / r.distance_m : 0.0, r.frames, r.rejected,
                  r.damaged, r.rtf, i + 1 < rows.size() ? "," : "");
    }
    std::printf("]\n");
  } else {
    std::printf("APE (SE(3) alignment) of the frontend on the simulated sequences; MRIO: paper Table II (real data)\n\n");
    std::printf("%-11s %9s %9s | %10s %10s | %10s %10s %8s | %7s %9s\n", "sequence", "dist (m)", "paper (m)",
                "MRIO t(m)", "MRIO r(deg)", "ours t(m)", "ours r(deg)", "% dist", "frames", "rejected");
    for (const Row& r : rows) {
      all_ok &= r.ok;
      if (!r.ok) {
        std::printf("%-11s %s\n", r.seq->name, r.error.c_str());
        continue;
      }
      std::printf("%-11s %9.2f %9.2f | %10.2f %10.2f | %10.3f %10.2f %8.2f | %7.0f %9.0f\n", r.seq->name, r.distance_m,
                  r.seq->paper_distance_m, r.seq->mrio_translation_m, r.seq->mrio_rotation_deg, r.translation_m,
                  r.rotation_deg, 100 * r.translation_m / std::max(r.distance_m, 1e-9), r.frames, r.rejected);
    }
    std::printf("\n(ours: the frontend alone, no backend; the paper's own full method: 0.19 / 0.42 / 2.04 / 1.05 / 0.97 m)\n");
  }
  return all_ok ? 0 : 1;
}

void print_stats(const char* name, const rsrio::eval::ErrorStats& s) {
  std::printf("%-26s rmse %9.4f  mean %9.4f  median %9.4f  std %9.4f  min %9.4f  max %9.4f\n", name, s.rmse, s.mean,
              s.median, s.std, s.min, s.max);
}
}  // namespace

int main(int argc, char** argv) {
  std::string gt, est, align = "se3", plot, delta = "1.0", max_dt = "0.01";
  std::string data_dir = "build/data", scenario_dir = "scenarios", sequences;
  bool do_table = false, table_json = false, reuse = false;
  rsrio::Cli cli("rsrio-eval", "Absolute and relative pose error of an estimate against ground truth (TUM files),\n"
                               "computed as evo_ape / evo_rpe do, with an optional trajectory plot.");
  cli.option("--gt", "GT.tum", "ground truth trajectory (TUM: t x y z qx qy qz qw)", &gt)
      .option("--est", "EST.tum", "estimated trajectory (TUM)", &est)
      .option("--align", "se3|se2|none", "Umeyama alignment before APE (default se3; se2 = yaw + translation)", &align)
      .option("--plot", "OUT.png", "write estimate and ground truth seen from above", &plot)
      .option("--delta", "M", "RPE pose-pair distance along the ground truth in metres (default 1)", &delta)
      .option("--max-dt", "S", "largest time difference when pairing stamps (default 0.01 s, as evo)", &max_dt)
      .flag("--table", "simulate (if missing), replay and evaluate the five scenarios: the paper's Table II", &do_table)
      .flag("--table-json", "as --table, the table as JSON on stdout", &table_json)
      .option("--data", "DIR", "--table: recordings and replays (default build/data)", &data_dir)
      .option("--scenarios", "DIR", "--table: the scenario files (default scenarios)", &scenario_dir)
      .option("--sequences", "LIST", "--table: only these sequences, e.g. 1,3 (default all five)", &sequences)
      .flag("--reuse", "--table: keep existing replay outputs instead of replaying", &reuse);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (do_table || table_json) {
    try {
      return table(data_dir, scenario_dir, sequences, cli.config_path(), reuse, table_json);
    } catch (const std::exception& ex) {
      std::cerr << "rsrio-eval: error: " << ex.what() << "\n";
      return 1;
    }
  }
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
