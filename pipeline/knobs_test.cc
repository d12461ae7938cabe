// Knobs declared once (knobs.h): parsing, stage keys, summary values, and the pipelines' lists.
#include "pipeline/knobs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "core/error.h"
#include "pipeline/pipeline.h"

namespace relume::pipeline {
namespace {

struct TestKnobs {
  int bins = 32;
  double spacing_m = 0.5;
  float threshold = 0.25f;
  bool penumbra = true;
  std::string frame = "enu";
  std::int64_t seed = 7;
  template <typename V>
  void VisitKnobs(V& v) {
    v.Knob("bins", bins, "bins", {"build"});
    v.Knob("spacing_m", spacing_m, "spacing", {"mesh"});
    v.Knob("threshold", threshold, "threshold", {"build", "relight"});
    v.Knob("penumbra", penumbra, "penumbra", {"view"});
    v.Knob("frame", frame, "frame", {"mesh"});
    v.Knob("seed", seed, "seed", {"report"});
  }
};

TEST(KnobsTest, SettingsParseIntoTheirFieldsAndOthersKeepTheirDefaults) {
  TestKnobs k;
  std::set<std::string> used;
  ApplySettings({{"bins", "16"}, {"threshold", "0.5"}, {"penumbra", "no"}, {"frame", "utm"}, {"other", "1"}}, k, &used);
  EXPECT_EQ(k.bins, 16);
  EXPECT_FLOAT_EQ(k.threshold, 0.5f);
  EXPECT_FALSE(k.penumbra);
  EXPECT_EQ(k.frame, "utm");
  EXPECT_DOUBLE_EQ(k.spacing_m, 0.5);
  EXPECT_EQ(k.seed, 7);
  EXPECT_EQ(used, (std::set<std::string>{"bins", "threshold", "penumbra", "frame"}));
}

TEST(KnobsTest, AValueThatDoesNotParseNamesTheKeyAndWhatItExpects) {
  for (const auto& [key, value, expected] :
       std::vector<std::tuple<std::string, std::string, std::string>>{{"bins", "1.5", "an integer"},
                                                                      {"bins", "", "an integer"},
                                                                      {"spacing_m", "inf", "a finite number"},
                                                                      {"spacing_m", "0.5m", "a finite number"},
                                                                      {"threshold", "nan", "a finite number"},
                                                                      {"penumbra", "maybe", "true or false"},
                                                                      {"seed", "x", "an integer"}}) {
    TestKnobs k;
    try {
      ApplySettings({{key, value}}, k, nullptr);
      ADD_FAILURE() << key << "=" << value << " was accepted";
    } catch (const InvalidArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find("--set " + key + "=" + value + ": expected " + expected), std::string::npos)
          << e.what();
    }
  }
}

TEST(KnobsTest, AStageKeyHoldsExactlyTheKnobsThatChangeThatStage) {
  const TestKnobs defaults;
  const std::string build = [&] {
    StageKey key;
    return AddKnobsToKey(key, defaults, "build").Describe();
  }();
  EXPECT_NE(build.find("bins"), std::string::npos) << build;
  EXPECT_NE(build.find("threshold"), std::string::npos) << build;
  EXPECT_EQ(build.find("spacing_m"), std::string::npos) << build;
  EXPECT_EQ(build.find("seed"), std::string::npos) << build;
  // Every knob of a stage changes its key; a knob of another stage does not.
  const auto key_of = [](const TestKnobs& k, const char* stage) {
    StageKey key;
    return AddKnobsToKey(key, k, stage).Hex();
  };
  TestKnobs changed = defaults;
  changed.threshold = 0.3f;
  EXPECT_NE(key_of(changed, "build"), key_of(defaults, "build"));
  EXPECT_NE(key_of(changed, "relight"), key_of(defaults, "relight"));
  EXPECT_EQ(key_of(changed, "mesh"), key_of(defaults, "mesh"));
  changed = defaults;
  changed.frame = "utm";
  EXPECT_NE(key_of(changed, "mesh"), key_of(defaults, "mesh"));
  EXPECT_EQ(key_of(changed, "build"), key_of(defaults, "build"));
}

TEST(KnobsTest, SummaryAndDescriptionCarryEveryKnob) {
  TestKnobs k;
  k.bins = 8;
  const nlohmann::json json = KnobsToJson(k);
  EXPECT_EQ(json["bins"], 8);
  EXPECT_EQ(json["frame"], "enu");
  EXPECT_EQ(json.size(), 6u);
  const std::vector<KnobInfo> info = DescribeKnobs<TestKnobs>();
  ASSERT_EQ(info.size(), 6u);
  EXPECT_EQ(info[0].name, "bins");
  EXPECT_EQ(info[0].type, "int");
  EXPECT_EQ(info[0].default_value, 32);
  EXPECT_EQ(info[2].stages, (std::vector<std::string>{"build", "relight"}));
}

// Every pipeline's knobs: unique names, at least one stage each, and a default that parses back
// as its own type (what `relume process --list` prints is a value --set accepts).
TEST(KnobsTest, EveryPipelineDeclaresItsKnobsOnceWithAStageAndAParsableDefault) {
  ASSERT_FALSE(Pipelines().empty());
  for (const PipelineEntry& entry : Pipelines()) {
    EXPECT_FALSE(entry.knobs.empty()) << entry.name;
    std::set<std::string> names;
    for (const KnobInfo& k : entry.knobs) {
      EXPECT_TRUE(names.insert(k.name).second) << entry.name << ": " << k.name << " declared twice";
      EXPECT_FALSE(k.stages.empty()) << entry.name << ": " << k.name;
      for (const std::string& tag : k.stages) {
        const bool known = tag == "plan" || tag == "report" || tag == "none" ||
                           std::find(entry.stage_tags.begin(), entry.stage_tags.end(), tag) != entry.stage_tags.end();
        EXPECT_TRUE(known) << entry.name << ": knob " << k.name << " names stage '" << tag
                           << "', which no stage key of the pipeline reads";
      }
      EXPECT_FALSE(k.help.empty()) << entry.name << ": " << k.name;
      const std::string text =
          k.default_value.is_string() ? k.default_value.get<std::string>() : k.default_value.dump();
      bool parsed = false;
      if (k.type == "bool") {
        bool v = false;
        parsed = ParseKnobValue(text, &v);
      } else if (k.type == "int") {
        std::int64_t v = 0;
        parsed = ParseKnobValue(text, &v);
      } else if (k.type == "number") {
        double v = 0.0;
        parsed = ParseKnobValue(text, &v);
      } else {
        parsed = k.type == "text";
      }
      EXPECT_TRUE(parsed) << entry.name << ": " << k.name << " default " << text << " (" << k.type << ")";
    }
  }
}

TEST(KnobsTest, UnknownSettingsAreRefusedWithTheClosestKnob) {
  EXPECT_NO_THROW(CheckSettings({{"bins", "16"}}, "irm"));
  EXPECT_NO_THROW(CheckSettings({{"bins", "16"}, {"sh_order", "1"}}, "all"));
  try {
    CheckSettings({{"bnis", "16"}}, "irm");
    ADD_FAILURE() << "a typo was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean bins?"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--list --pipeline irm"), std::string::npos) << e.what();
  }
  // A knob of another pipeline is not one of this pipeline's.
  EXPECT_THROW(CheckSettings({{"sh_order", "1"}}, "irm"), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::pipeline
