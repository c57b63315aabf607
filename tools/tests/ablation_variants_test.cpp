// rsrio-eval's ablation variants (tools/ablation_variants.hpp): each one's options file, made as
// rsrio-eval makes it (the shipped config/rsrio.yaml with the variant's backend: section
// appended), loads as rsrio-replay loads it. The sliding window over every keyframe once asked for
// more keyframe images than keyframe points, which the backend's options refuse, and every replay
// of that row failed at start-up.
#include <catch2/catch_test_macros.hpp>

#include <string>

#include "../ablation_variants.hpp"
#include "replay_options.hpp"
#include "scratch_dir.hpp"

namespace {

std::string shipped_options() { return rsrio::testing::file_text("config/rsrio.yaml"); }

rsrio::splat::BackendOptions load_as_replay(const std::string& path) {
  return rsrio::testing::load_as_replay(path).backend;
}

}  // namespace

TEST_CASE("Ablation variants: every variant's options load as the replay loads them", "[eval][ablation]") {
  const rsrio::testing::ScratchDir dir("ablation_variants_test");
  const std::string base = shipped_options();
  // rsrio-eval refuses a base file with a backend: section of its own (the variants set it).
  REQUIRE(base.find("\nbackend:") == std::string::npos);
  for (const rsrio::ablation::Variant& v : rsrio::ablation::kAblations) {
    INFO(v.key);
    // As rsrio-eval: a variant without overrides (the backend off) replays with the file as it is.
    const std::string overrides = v.overrides;
    const std::string path =
        dir.write(std::string(v.key) + ".yaml", overrides.empty() ? base : base + "backend:\n" + overrides);
    rsrio::splat::BackendOptions o;
    try {
      o = load_as_replay(path);
    } catch (const rsrio::ConfigError& e) {
      FAIL(v.key << ": " << e.what());
    }
    const std::string key = v.key;
    if (key == "ablation_ninf") {
      // Every keyframe's images stay for the window over all of them: the longest sequence has
      // ~550 keyframes.
      CHECK(o.ba_window == "sliding");
      CHECK(o.ba_max_keyframes >= 1000);
      CHECK(o.max_keyframe_images >= 1000);
    }
    if (key == "ablation_nord") CHECK_FALSE(o.rd_loss);
    if (key == "ablation_noba") CHECK(o.ba.max_iterations == 0);
  }
}

TEST_CASE("Ablation variants: a variant the backend's options refuse is caught here", "[eval][ablation]") {
  // The sliding window over every keyframe as it once was: more images than points kept.
  const rsrio::testing::ScratchDir dir("ablation_variants_refused");
  const std::string path = dir.write(
      "ninf_before.yaml", shipped_options() + "backend:\n  ba_window: sliding\n  ba_sliding_keyframes: 1000\n"
                                              "  ba_max_keyframes: 1000\n  max_keyframe_images: 100000\n");
  try {
    load_as_replay(path);
    FAIL("no ConfigError");
  } catch (const rsrio::ConfigError& e) {
    CHECK(e.key().find("max_keyframe_points") != std::string::npos);
  }
}
