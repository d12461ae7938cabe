// Summaries and stage records declared once (fields.h): JSON written and read back through the
// same field list, what reading tolerates and what it refuses, and every pipeline's summary.
#include "pipeline/fields.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/testing/temp_files.h"
#include "pipeline/irm_pipeline.h"
#include "pipeline/pipeline.h"
#include "pipeline/radiosity_pipeline.h"
#include "pipeline/sh_pipeline.h"

namespace relume::pipeline {

namespace other_layer {
// A type of another layer, with its field list as a free function found by argument-dependent
// lookup (as pipeline does for processing's result types).
struct Counts {
  int a = 0;
  std::int64_t b = 0;
};
template <typename V>
void VisitFields(V& v, Counts& c) {
  v.Field("a", c.a);
  v.Field("b", c.b);
}
}  // namespace other_layer

namespace {

struct Inner {
  std::string name;
  Eigen::Vector3f rgb = Eigen::Vector3f::Zero();
  template <typename V>
  void VisitFields(V& v) {
    v.Field("name", name);
    v.Field("rgb", rgb);
  }
};

struct Outer {
  bool flag = false;
  int count = 0;
  std::int64_t big = 0;
  float f = 0.0f;
  double d = 0.0;
  std::string text;
  std::optional<double> maybe;
  std::optional<Inner> maybe_inner;
  std::vector<Inner> inners;
  std::vector<double> values;
  std::map<std::string, double> by_name;
  Eigen::Vector3d v3 = Eigen::Vector3d::Zero();
  other_layer::Counts counts;  // a nested object
  other_layer::Counts flat;    // its fields at this level
  template <typename V>
  void VisitFields(V& v) {
    v.Field("flag", flag);
    v.Field("count", count);
    v.Field("big", big);
    v.Field("f", f);
    v.Field("d", d);
    v.Field("text", text);
    v.Field("maybe", maybe);
    v.Field("maybe_inner", maybe_inner);
    v.Field("inners", inners);
    v.Field("values", values);
    v.Field("by_name", by_name);
    v.Field("v3", v3);
    v.Field("counts", counts);
    other_layer::VisitFields(v, flat);
  }
};

Outer Sample() {
  Outer o;
  o.flag = true;
  o.count = -3;
  o.big = std::int64_t{1} << 40;
  o.f = 0.1f;
  o.d = 1.0 / 3.0;
  o.text = "sky";
  o.maybe = 2.5;
  o.maybe_inner = Inner{"lamp", {1.0f, 0.5f, 0.25f}};
  o.inners = {Inner{"a", {0.1f, 0.2f, 0.3f}}, Inner{"b", {4.0f, 5.0f, 6.0f}}};
  o.values = {1.0, 2.0};
  o.by_name = {{"wall", 0.7}, {"floor", 0.3}};
  o.v3 = {1.0, -2.0, 3.5};
  o.counts = {4, 5};
  o.flat = {6, 7};
  return o;
}

TEST(FieldsTest, WritesEveryFieldAndReadsItBackExactly) {
  const Outer o = Sample();
  const nlohmann::json j = FieldsToJson(o);
  EXPECT_EQ(j["count"], -3);
  EXPECT_EQ(j["big"], std::int64_t{1} << 40);
  EXPECT_EQ(j["maybe_inner"]["name"], "lamp");
  EXPECT_EQ(j["inners"][1]["rgb"][2], 6.0f);
  EXPECT_EQ(j["by_name"]["wall"], 0.7);
  EXPECT_EQ(j["counts"]["b"], 5);
  EXPECT_EQ(j["a"], 6);  // the free field list flattened into this object
  EXPECT_EQ(j["b"], 7);

  // Through text, as a file holds it: floats and doubles come back bit for bit.
  const Outer back = FieldsFromJson<Outer>(nlohmann::json::parse(j.dump()), "test.json");
  EXPECT_EQ(back.f, o.f);
  EXPECT_EQ(back.d, o.d);
  EXPECT_EQ(back.big, o.big);
  EXPECT_EQ(back.maybe, o.maybe);
  ASSERT_TRUE(back.maybe_inner.has_value());
  EXPECT_EQ(back.maybe_inner->rgb, o.maybe_inner->rgb);
  ASSERT_EQ(back.inners.size(), 2u);
  EXPECT_EQ(back.inners[1].name, "b");
  EXPECT_EQ(back.by_name, o.by_name);
  EXPECT_EQ(back.v3, o.v3);
  EXPECT_EQ(back.counts.b, 5);
  EXPECT_EQ(back.flat.a, 6);
  EXPECT_EQ(FieldsToJson(back), j);
}

TEST(FieldsTest, AnAbsentOptionalIsLeftOutAndNonFiniteNumbersAreNull) {
  Outer o;
  o.d = std::numeric_limits<double>::quiet_NaN();
  o.f = std::numeric_limits<float>::infinity();
  o.v3 = {1.0, std::numeric_limits<double>::quiet_NaN(), 2.0};
  const nlohmann::json j = FieldsToJson(o);
  EXPECT_FALSE(j.contains("maybe"));
  EXPECT_FALSE(j.contains("maybe_inner"));
  EXPECT_TRUE(j["d"].is_null());
  EXPECT_TRUE(j["f"].is_null());
  EXPECT_TRUE(j["v3"][1].is_null());
  const Outer back = FieldsFromJson<Outer>(j, "test.json");
  EXPECT_TRUE(std::isnan(back.d));
  EXPECT_TRUE(std::isnan(back.f));  // written as null: read back as NaN, not as infinity
  EXPECT_TRUE(std::isnan(back.v3[1]));
  EXPECT_EQ(back.v3[2], 2.0);
  EXPECT_FALSE(back.maybe.has_value());
}

TEST(FieldsTest, MissingKeysKeepTheirDefaultsAndUnknownKeysAreIgnored) {
  // An older file lacks newer figures; a newer one may hold figures this version does not know.
  const nlohmann::json j = {{"count", 9}, {"maybe", nullptr}, {"a_figure_of_a_later_version", 1.5}};
  const Outer back = FieldsFromJson<Outer>(j, "old.json");
  EXPECT_EQ(back.count, 9);
  EXPECT_EQ(back.text, "");
  EXPECT_FALSE(back.maybe.has_value());
  EXPECT_TRUE(back.inners.empty());
}

TEST(FieldsTest, AFieldOfTheWrongTypeIsAnIoErrorNamingTheFileAndTheField) {
  nlohmann::json j = FieldsToJson(Sample());
  j["inners"][1]["name"] = 42;
  try {
    FieldsFromJson<Outer>(j, "/out/stage/record.json");
    FAIL() << "a number where text belongs was accepted";
  } catch (const IoError& e) {
    EXPECT_EQ(e.path(), "/out/stage/record.json");
    EXPECT_NE(std::string(e.what()).find("inners[1].name"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected text"), std::string::npos) << e.what();
  }
  j = FieldsToJson(Sample());
  j["count"] = 2.5;  // not an integer
  EXPECT_THROW(FieldsFromJson<Outer>(j, "x.json"), IoError);
  j = FieldsToJson(Sample());
  j["v3"] = {1.0, 2.0};  // the vector's size is 3
  EXPECT_THROW(FieldsFromJson<Outer>(j, "x.json"), IoError);
  EXPECT_THROW(FieldsFromJson<Outer>(nlohmann::json::array(), "x.json"), IoError);
}

TEST(FieldsTest, RecordsGoThroughTheirFiles) {
  const std::filesystem::path dir = relume::testing::FreshTempDir("FieldsTest", "RecordsGoThroughTheirFiles");
  WriteRecord(dir / "record.json", Sample());
  EXPECT_EQ(FieldsToJson(ReadRecord<Outer>(dir / "record.json")), FieldsToJson(Sample()));
  EXPECT_THROW(ReadRecord<Outer>(dir / "missing.json"), IoError);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() { std::filesystem::remove_all(dir); }
  } cleanup{dir};
  { std::ofstream(dir / "cut.json") << "{\"count\": 1, \"text\": \"cut sh"; }
  try {
    ReadRecord<Outer>(dir / "cut.json");
    FAIL() << "a cut-short record was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos) << e.what();
  }
}

// Each pipeline's summary with every optional part present survives summary.json: its headline
// and figures read the same from the written JSON as from the typed values.
template <typename Summary>
void ExpectRoundTrip(const Summary& s) {
  const nlohmann::json j = FieldsToJson(s);
  EXPECT_EQ(FieldsToJson(FieldsFromJson<Summary>(nlohmann::json::parse(j.dump()), "summary.json")), j) << j.dump(1);
}

TEST(FieldsTest, EveryPipelineSummaryRoundTrips) {
  IrmSummary irm;
  irm.irm.emplace();
  irm.irm->relight.summary.pixels_relit = 1234;
  irm.irm->relight.seam.overlap_relative_rms_after = 0.02;
  irm.irm->indirect.scale_over_sky_prediction = Eigen::Vector3f(0.9f, 1.0f, 1.1f);
  irm.irm->sky_shape.source.reason = "no sky in view";
  irm.truth.emplace();
  irm.truth->relit.shadow = 0.031;
  irm.truth->source_photograph = metrics::SunRegionErrors{};
  ExpectRoundTrip(irm);

  ShPipelineSummary sh;
  sh.frames.emplace();
  ShFrameFigures& frame = sh.frames->emplace_back();
  frame.fit.segment_albedo = std::vector<Eigen::Vector3d>{{0.5, 0.4, 0.3}};
  frame.relight = ShRelightFigures{10, 9, 1, 0, 3, 2, "ok"};
  frame.destination_photo_relative_rms = 0.04;
  frame.destination_photo_pixels = 9;
  frame.truth.relit_relative_rms = 0.05;
  ShCastShadowFigures shadows{3, 0.1, 0.8, 0.2, 20.5, 0.48, 2.8, 4120};
  sh.cast_shadows = ShCastShadowsSummary{0.2, 0.48, 2.8, {shadows}};
  sh.sh_fits_scene = false;
  sh.misfit_reasons = std::vector<std::string>{kResidualReason, kSunShadowsReason, kDestinationPhotoReason};
  sh.destination_photo_relative_rms_median = 0.04;
  sh.destination_photo_frames = 1;
  sh.clipped_frames = 2;
  ExpectRoundTrip(sh);

  RadiosityPipelineSummary radiosity;
  radiosity.patches = 300;
  radiosity.reflectance.emplace();
  radiosity.reflectance->truth_after.emplace();
  radiosity.reflectance->truth_after->materials.push_back(
      {"wall", {0.7, 0.7, 0.7}, {0.69, 0.7, 0.71}, 0.01, 40, std::nullopt, 0.02, 0.01});
  radiosity.reflectance->model_gap_true_albedo_vs_bracket0 = ModelGapFigures{{0.01, 0.02, 30}, std::nullopt};
  radiosity.relight = RadiosityRelightRecord{};
  radiosity.relight->truth_relative_rms_per_pixel = 0.04;
  ExpectRoundTrip(radiosity);
}

TEST(FieldsTest, HeadlinesAndFiguresReadTheWrittenSummary) {
  IrmSummary irm;
  irm.irm.emplace();
  irm.truth.emplace();
  irm.truth->relit.lit = 0.012;
  irm.truth->relit.shadow = 0.034;
  const PipelineEntry* entry = nullptr;
  for (const PipelineEntry& e : Pipelines()) {
    if (e.name == "irm") entry = &e;
  }
  ASSERT_NE(entry, nullptr);
  const nlohmann::json metrics = FieldsToJson(irm);
  const std::string headline = entry->headline(metrics);
  EXPECT_NE(headline.find("lit 1.2 %, shadow 3.4 %"), std::string::npos) << headline;
  bool shadow_figure = false;
  for (const Figure& f : entry->figures(metrics)) {
    if (f.label.rfind("relit vs truth, shadow", 0) == 0) shadow_figure = f.value == "3.40" && f.unit == "%";
  }
  EXPECT_TRUE(shadow_figure);
  // A planned-only run's summary (no result) has nothing to say, and a summary that holds a
  // figure of the wrong type is refused with its place named.
  EXPECT_EQ(entry->headline(nlohmann::json::object()), "");
  nlohmann::json bad = metrics;
  bad["truth"]["relit"]["relative_rms_lit"] = "low";
  EXPECT_THROW(entry->headline(bad), IoError);
}

}  // namespace
}  // namespace relume::pipeline
