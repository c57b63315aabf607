// rsrio-eval: APE and RPE of an estimate against ground truth, as evo computes them, and a plot.
//
//   rsrio-eval --gt GT.tum --est EST.tum [--align se3|se2|none] [--plot OUT.png] [--legs]
//   rsrio-eval --table | --table-json | --ablation [--data DIR] [--scenarios DIR] [--sequences 1,2,...] [--config FILE] [--reuse]
//   rsrio-eval --ablation --variants full,noba,... (only these rows; names as the output directories)
//   rsrio-eval --table | --ablation ... --repeatable
//
// --table reproduces the paper's Table II for the five shipped scenarios (scenarios/seq1..seq5):
// it makes each recording with rsrio-sim when DIR/<scenario>.mcap is missing, replays it with
// rsrio-replay --backend ba (--config FILE is passed on: the pipeline options, default
// config/rsrio.yaml when present) and prints the APE (SE(3) Umeyama alignment, one pair per
// estimated pose) of the frontend and of the full method, next to the paper's columns.
// --ablation replays each sequence once per variant of the paper's Tables III and IV (into
// DIR/<scenario>_ablation_<variant>) and prints their APE averaged over the sequences; --variants
// replays only some of them (a whole ablation of the five sequences takes hours).
// --repeatable replays with rsrio-replay --repeatable (the backend without its stages' time
// budgets: the same figures on any machine and load, slower than real time) into directories
// named with _repeatable at the end, apart from the real-time replays.
// rsrio-sim and rsrio-replay are taken from the directory of this program.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rsrio/common/cli.hpp"
#include "rsrio/eval/plot.hpp"
#include "rsrio/eval/trajectory.hpp"
#include "ablation_variants.hpp"
#include "cli_numbers.hpp"

namespace {
namespace fs = std::filesystem;
using rsrio::ablation::kAblations;
using rsrio::ablation::kFull;
using rsrio::ablation::Variant;

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

// One replay of one sequence with one set of backend options, evaluated.
struct Run {
  bool ok = false;
  std::string error;
  double distance_m = 0;
  double frontend_t = 0, frontend_r = 0;  // APE of frontend.tum
  double full_t = 0, full_r = 0;          // APE of estimate.tum (= frontend with backend none)
  bool has_final = false;                 // estimate_final.tum (a backend ran)
  double final_t = 0, final_r = 0;        // APE of estimate_final.tum: the map's trajectory at the end
  double frames = 0, rejected = 0, damaged = 0, rtf = 0;
};

class Tables {
 public:
  Tables(std::string data_dir, std::string scenario_dir, std::string config, bool reuse, bool repeatable)
      : data_(std::move(data_dir)),
        scenarios_(std::move(scenario_dir)),
        config_(std::move(config)),
        reuse_(reuse),
        repeatable_(repeatable) {
    const fs::path bin = fs::read_symlink("/proc/self/exe").parent_path();
    sim_ = (bin / "rsrio-sim").string();
    replay_ = (bin / "rsrio-replay").string();
    for (const auto& p : {sim_, replay_})
      if (!fs::exists(p))
        throw std::runtime_error(p + " not found (--table needs rsrio-sim and rsrio-replay next to rsrio-eval; build them)");
    if (config_.empty() && fs::exists("config/rsrio.yaml")) config_ = "config/rsrio.yaml";
    if (!config_.empty()) {
      std::ifstream f(config_);
      if (!f) throw std::runtime_error(config_ + ": cannot read");
      std::stringstream t;
      t << f.rdbuf();
      base_ = t.str();
    }
    fs::create_directories(data_);
  }

  Run evaluate(const Sequence& seq, const Variant& v) {
    Run r;
    const std::string name = seq.scenario;
    const fs::path rec = fs::path(data_) / (name + ".mcap");
    const fs::path out = fs::path(data_) / (name + "_" + v.key + (repeatable_ ? "_repeatable" : ""));
    const std::string log = (fs::path(data_) / (name + ".log")).string();
    if (!fs::exists(rec)) {
      const std::string part = rec.string() + ".part";
      if (run({sim_, "--scenario", (fs::path(scenarios_) / (name + ".yaml")).string(), "--out", part}, log) != 0) {
        r.error = "rsrio-sim failed (see " + log + ")";
        return r;
      }
      fs::rename(part, rec);
    }
    if (!reuse_ || !made_with(out, v.backend)) {
      std::vector<std::string> args{replay_, "--quiet", "--input", rec.string(), "--out", out.string(), "--backend",
                                    v.backend};
      std::string config = config_;
      if (*v.overrides) {
        // The variant's options: the pipeline's file with a backend: section appended.
        if (base_.find("\nbackend:") != std::string::npos || base_.rfind("backend:", 0) == 0)
          throw std::runtime_error(config_ + ": the ablations set the backend: section themselves; use a file without it");
        fs::create_directories(out);
        config = (out / "options.yaml").string();
        std::ofstream f(config);
        f << base_ << (base_.empty() || base_.back() == '\n' ? "" : "\n") << "backend:\n" << v.overrides;
      }
      if (!config.empty()) args.insert(args.end(), {"--config", config});
      if (v.replay_option != nullptr) args.emplace_back(v.replay_option);
      // Only the backend has time budgets; the frontend alone is repeatable as it is.
      if (repeatable_ && std::string(v.backend) == "ba") args.emplace_back("--repeatable");
      if (run(args, log) != 0) {
        r.error = "rsrio-replay failed (see " + log + ")";
        return r;
      }
    }
    try {
      const auto gt = rsrio::eval::read_tum((out / "ground_truth.tum").string());
      auto ape_of = [&](const char* file, double& t, double& rot) {
        const auto est = rsrio::eval::read_tum((out / file).string());
        rsrio::eval::Trajectory e, g;
        rsrio::eval::associate(est, gt, 0.01, e, g);  // one pair per estimated pose
        if (e.size() < 3) throw std::runtime_error(std::string(file) + ": fewer than 3 poses pair with the ground truth");
        const auto a = rsrio::eval::ape(g, e, rsrio::eval::Alignment::kSE3);
        t = a.translation_m.rmse;
        rot = a.rotation_deg.rmse;
        return a.path_length_m;
      };
      r.distance_m = ape_of("frontend.tum", r.frontend_t, r.frontend_r);
      ape_of("estimate.tum", r.full_t, r.full_r);
      r.has_final = fs::exists(out / "estimate_final.tum");
      if (r.has_final) ape_of("estimate_final.tum", r.final_t, r.final_r);
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
    return r;
  }

 private:
  // A replay output made with this backend (--reuse keeps it).
  static bool made_with(const fs::path& out, const std::string& backend) {
    std::ifstream f(out / "stats.json");
    std::stringstream t;
    t << f.rdbuf();
    return fs::exists(out / "estimate.tum") && t.str().find("\"backend\": \"" + backend + "\"") != std::string::npos;
  }
  std::string data_, scenarios_, config_, base_, sim_, replay_;
  bool reuse_, repeatable_;
};

std::vector<std::size_t> selected(const std::string& sequences) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < kSequences.size(); ++i)
    if (sequences.empty() || ("," + sequences + ",").find("," + std::to_string(i + 1) + ",") != std::string::npos)
      out.push_back(i);
  return out;
}

double reduction(double before, double after) { return before > 0 ? 100.0 * (before - after) / before : 0.0; }

// Table II: the frontend and the full method (frontend + RadarSplat++ BA) on each sequence.
int table(Tables& tables, const std::string& sequences, bool json) {
  bool all_ok = true;
  std::vector<std::pair<const Sequence*, Run>> rows;
  for (std::size_t i : selected(sequences)) rows.emplace_back(&kSequences[i], tables.evaluate(kSequences[i], kFull));
  if (json) {
    std::printf("[\n");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const auto& [seq, r] = rows[i];
      all_ok &= r.ok;
      std::printf("  {\"sequence\": \"%s\", \"scenario\": \"%s\", \"ok\": %s, \"error\": \"%s\", "
                  "\"distance_m\": %.3f, \"paper_distance_m\": %.2f, \"mrio_translation_m\": %.2f, "
                  "\"mrio_rotation_deg\": %.2f, \"paper_full_translation_m\": %.2f, \"paper_full_rotation_deg\": %.2f, "
                  "\"frontend_translation_m\": %.4f, \"frontend_rotation_deg\": %.3f, "
                  "\"full_translation_m\": %.4f, \"full_rotation_deg\": %.3f, "
                  "\"translation_reduction_percent\": %.1f, \"rotation_reduction_percent\": %.1f, "
                  "\"end_of_run_translation_m\": %.4f, \"end_of_run_rotation_deg\": %.3f, "
                  "\"end_of_run_translation_reduction_percent\": %.1f, \"end_of_run_rotation_reduction_percent\": %.1f, "
                  "\"frames\": %.0f, \"rejected_frames\": %.0f, \"damaged_frames\": %.0f, "
                  "\"replay_real_time_factor\": %.2f}%s\n",
                  seq->name, seq->scenario, r.ok ? "true" : "false", r.error.c_str(), r.distance_m,
                  seq->paper_distance_m, seq->mrio_translation_m, seq->mrio_rotation_deg, seq->paper_ours_translation_m,
                  seq->paper_ours_rotation_deg, r.frontend_t, r.frontend_r, r.full_t, r.full_r,
                  reduction(r.frontend_t, r.full_t), reduction(r.frontend_r, r.full_r), r.final_t, r.final_r,
                  reduction(r.frontend_t, r.final_t), reduction(r.frontend_r, r.final_r), r.frames, r.rejected,
                  r.damaged, r.rtf, i + 1 < rows.size() ? "," : "");
    }
    std::printf("]\n");
    return all_ok ? 0 : 1;
  }
  std::printf("Table II: APE (SE(3) alignment) on the simulated sequences. Paper: MRIO and the paper's full method on\n"
              "real data; ours: our frontend alone and with the RadarSplat++ backend (BA), from one replay: the\n"
              "published (causal) trajectory, and the one the map has at the end (estimate_final.tum).\n\n");
  std::printf("%-11s %8s | %6s %6s | %6s %6s | %8s %8s | %8s %8s | %6s %6s | %7s %6s | %6s %6s | %5s\n", "sequence",
              "dist(m)", "MRIO t", "r", "paper t", "r", "front t", "r(deg)", "full t", "r(deg)", "-t %", "-r %", "end t",
              "r", "-t %", "-r %", "RTF");
  for (const auto& [seq, r] : rows) {
    all_ok &= r.ok;
    if (!r.ok) {
      std::printf("%-11s %s\n", seq->name, r.error.c_str());
      continue;
    }
    std::printf("%-11s %8.2f | %6.2f %6.2f | %6.2f %6.2f | %8.3f %8.2f | %8.3f %8.2f | %6.1f %6.1f | ", seq->name,
                r.distance_m, seq->mrio_translation_m, seq->mrio_rotation_deg, seq->paper_ours_translation_m,
                seq->paper_ours_rotation_deg, r.frontend_t, r.frontend_r, r.full_t, r.full_r,
                reduction(r.frontend_t, r.full_t), reduction(r.frontend_r, r.full_r));
    if (r.has_final)
      std::printf("%7.3f %6.2f | %6.1f %6.1f | %5.2f\n", r.final_t, r.final_r, reduction(r.frontend_t, r.final_t),
                  reduction(r.frontend_r, r.final_r), r.rtf);
    else
      std::printf("%7s %6s | %6s %6s | %5.2f\n", "-", "-", "-", "-", r.rtf);
  }
  std::printf("\n(-t %%, -r %%: APE reduction of the full method over the frontend; the paper's: ~90 %% / ~80 %%.\n"
              " full: the poses as published, each when its frame came; end: every frame's pose as the map has it\n"
              " at the end of the run, after the later BA and loop closures (not causal).\n"
              " RTF: the replay's real-time factor with the backend, on this machine.)\n");
  return all_ok ? 0 : 1;
}

// A variant's name on the command line: its directory suffix without "ablation_", "full" for the
// full method.
std::string variant_name(const Variant& v) {
  const std::string key = v.key;
  return &v == &kFull ? "full" : key.substr(key.find('_') + 1);
}

// The variants named in a comma-separated list (all when it is empty), in the tables' order; an
// unknown name throws std::invalid_argument listing the names (a usage error).
std::vector<const Variant*> selected_variants(const std::string& list) {
  std::vector<const Variant*> all{&kFull};
  for (const Variant& v : kAblations) all.push_back(&v);
  if (list.empty()) return all;
  std::vector<std::string> names;
  std::stringstream in(list);
  for (std::string name; std::getline(in, name, ',');) names.push_back(name);
  for (const std::string& name : names) {
    bool known = false;
    for (const Variant* v : all) known |= variant_name(*v) == name;
    if (!known) {
      std::string valid;
      for (const Variant* v : all) valid += (valid.empty() ? "" : ", ") + variant_name(*v);
      throw std::invalid_argument("--variants: unknown variant '" + name + "' (one of: " + valid + ")");
    }
  }
  std::vector<const Variant*> out;
  for (const Variant* v : all)
    if (std::find(names.begin(), names.end(), variant_name(*v)) != names.end()) out.push_back(v);
  return out;
}

// Tables III and IV: each variant's APE averaged over the selected sequences (as the paper).
int ablation(Tables& tables, const std::string& sequences, const std::vector<const Variant*>& variants) {
  struct Line {
    explicit Line(const Variant* variant) : v(variant) {}
    const Variant* v;
    double t = 0, r = 0;
    double final_t = 0, final_r = 0;  // end of run (estimate_final.tum)
    int n = 0, n_final = 0;
    std::string error;
  };
  std::vector<Line> lines;
  for (const Variant* v : variants) lines.emplace_back(v);
  for (std::size_t i : selected(sequences))
    for (Line& l : lines) {
      const Run result = tables.evaluate(kSequences[i], *l.v);
      if (!result.ok) {
        l.error += std::string(kSequences[i].name) + ": " + result.error + "; ";
        continue;
      }
      l.t += result.full_t;
      l.r += result.full_r;
      ++l.n;
      if (result.has_final) {
        l.final_t += result.final_t;
        l.final_r += result.final_r;
        ++l.n_final;
      }
    }
  std::printf("Tables III and IV: APE averaged over sequences %s (simulated). Paper (all sequences, real data) in [].\n\n",
              sequences.empty() ? "1-5" : sequences.c_str());
  std::printf("%-54s %10s %10s %12s   %s\n", "variant", "trans (m)", "rot (deg)", "end t / r", "paper t / r");
  bool ok = true;
  for (const Line& l : lines) {
    if (l.n == 0) {
      std::printf("%-54s %s\n", l.v->label, l.error.c_str());
      ok = false;
      continue;
    }
    char end[32] = "-";
    if (l.n_final == l.n) std::snprintf(end, sizeof end, "%.3f / %.2f", l.final_t / l.n, l.final_r / l.n);
    std::printf("%-54s %10.3f %10.2f %12s   %s%s\n", l.v->label, l.t / l.n, l.r / l.n, end, l.v->paper,
                l.error.empty() ? "" : "  (some sequences failed)");
  }
  std::printf("\n(trans, rot: the published trajectory; end: as the map has it at the end of the run, not causal.)\n");
  return ok ? 0 : 1;
}

void print_stats(const char* name, const rsrio::eval::ErrorStats& s) {
  std::printf("%-26s rmse %9.4f  mean %9.4f  median %9.4f  std %9.4f  min %9.4f  max %9.4f\n", name, s.rmse, s.mean,
              s.median, s.std, s.min, s.max);
}
}  // namespace

int main(int argc, char** argv) {
  std::string gt, est, align = "se3", plot, delta = "1.0", max_dt = "0.01";
  std::string data_dir = "build/data", scenario_dir = "scenarios", sequences, variants;
  bool do_table = false, table_json = false, reuse = false, do_ablation = false, repeatable = false, legs = false;
  rsrio::Cli cli("rsrio-eval", "Absolute and relative pose error of an estimate against ground truth (TUM files),\n"
                               "computed as evo_ape / evo_rpe do, with an optional trajectory plot.");
  cli.option("--gt", "GT.tum", "ground truth trajectory (TUM: t x y z qx qy qz qw)", &gt)
      .option("--est", "EST.tum", "estimated trajectory (TUM)", &est)
      .option("--align", "se3|se2|none", "Umeyama alignment before APE (default se3; se2 = yaw + translation)", &align)
      .option("--plot", "OUT.png", "write estimate and ground truth seen from above", &plot)
      .option("--delta", "M", "RPE pose-pair distance along the ground truth in metres (default 1)", &delta)
      .flag("--legs", "also each straight leg of the ground truth and the distance the estimate covers over it", &legs)
      .option("--max-dt", "S", "largest time difference when pairing stamps (default 0.01 s, as evo)", &max_dt)
      .flag("--table", "simulate (if missing), replay and evaluate the five scenarios: the paper's Table II", &do_table)
      .flag("--table-json", "as --table, the table as JSON on stdout", &table_json)
      .option("--data", "DIR", "--table: recordings and replays (default build/data)", &data_dir)
      .option("--scenarios", "DIR", "--table: the scenario files (default scenarios)", &scenario_dir)
      .option("--sequences", "LIST", "--table: only these sequences, e.g. 1,3 (default all five)", &sequences)
      .flag("--ablation", "as --table, the ablations of the paper's Tables III and IV (averaged over the sequences)",
            &do_ablation)
      .option("--variants", "LIST", "--ablation: only these rows, e.g. full,noba,r1 (default all; names as the "
              "output directories' ablation_<name>, full for the full method)", &variants)
      .flag("--reuse", "--table: keep existing replay outputs instead of replaying", &reuse)
      .flag("--repeatable", "--table, --ablation: replay without the backend's time budgets (the same figures on any "
            "machine; slower than real time), into <scenario>_<row>_repeatable", &repeatable);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  std::vector<const Variant*> rows;
  try {
    if (!variants.empty() && !do_ablation) throw std::invalid_argument("--variants needs --ablation");
    if (repeatable && !(do_table || table_json || do_ablation))
      throw std::invalid_argument("--repeatable needs --table, --table-json or --ablation");
    rows = selected_variants(variants);
  } catch (const std::invalid_argument& ex) {
    return cli.usage_error(ex.what());
  }
  if (do_table || table_json || do_ablation) {
    try {
      Tables tables(data_dir, scenario_dir, cli.config_path(), reuse, repeatable);
      return do_ablation ? ablation(tables, sequences, rows) : table(tables, sequences, table_json);
    } catch (...) {
      return rsrio::report_program_error("rsrio-eval", std::current_exception());
    }
  }
  if (gt.empty() || est.empty()) return cli.usage_error("--gt and --est are required");
  double d = 0, dt = 0;
  if (!rsrio::tools::parse_double(delta, d) || d <= 0) return cli.usage_error("--delta: expected metres > 0, got '" + delta + "'");
  if (!rsrio::tools::parse_double(max_dt, dt) || dt < 0)
    return cli.usage_error("--max-dt: expected seconds >= 0, got '" + max_dt + "'");
  try {
    const auto alignment = rsrio::eval::parse_alignment(align);
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
    print_stats("  heading (deg, +left)", a.heading_deg);
    print_stats("  tilt (deg)", a.tilt_deg);
    std::printf("%-26s %.2f %% of the path\n", "APE translation rmse", 100.0 * a.translation_m.rmse / a.path_length_m);
    char label[64];
    std::snprintf(label, sizeof label, "RPE translation (m/%gm)", d);
    print_stats(label, r.translation_m);
    std::snprintf(label, sizeof label, "RPE rotation (deg/%gm)", d);
    print_stats(label, r.rotation_deg);
    const auto aligned = rsrio::eval::transformed(ea, a.alignment);
    const auto track = rsrio::eval::track_errors(ra, aligned);
    std::printf("while the ground truth moves (>= 0.2 m/s, %zu poses), the aligned error in the plane:\n",
                track.along_m.count);
    print_stats("  along track (m, +ahead)", track.along_m);
    print_stats("  across track (m, +left)", track.across_m);
    if (legs) {
      const auto list = rsrio::eval::straight_legs(ra, ea);
      std::printf("straight legs of the ground truth (between stops and turns of 15 deg), end to end in the plane:\n");
      std::printf("%10s %10s %8s %10s %10s %9s\n", "t0 (s)", "t1 (s)", "heading", "gt (m)", "est (m)", "est/gt");
      for (const auto& l : list)
        std::printf("%10.1f %10.1f %8.0f %10.3f %10.3f %9.4f\n", l.t_begin - ra.front().t, l.t_end - ra.front().t,
                    l.heading_deg, l.ref_m, l.est_m, l.est_m / l.ref_m);
    }
    if (!plot.empty()) {
      rsrio::eval::plot_xy(plot, {{"ground truth", &ra, {60, 60, 60}}, {"estimate (aligned)", &aligned, {40, 40, 220}}},
                           "APE " + std::to_string(a.translation_m.rmse).substr(0, 5) + " m rmse");
      std::printf("plot: %s\n", plot.c_str());
    }
  } catch (const std::invalid_argument& ex) {
    // --align naming no alignment: the command line's fault.
    return cli.usage_error(ex.what());
  } catch (...) {
    // A TUM file that is missing or malformed: the data's, not the command line's.
    return rsrio::report_program_error("rsrio-eval", std::current_exception());
  }
  return 0;
}
