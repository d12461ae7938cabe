// The structure of `relume bench --quick`'s bench.csv (written by the cli.bench.quick test, a
// CTest fixture of this one; its path in RELUME_BENCH_CSV): every stage present with finite,
// positive times and finite errors, and each planner skip beside its forced run (times reported, not asserted).
// Absolute run times are not asserted.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace {

struct CsvRow {
  std::map<std::string, std::string> field;
  double Number(const std::string& name) const { return std::stod(field.at(name)); }
};

// Splits one CSV line; fields may be quoted (no quotes inside quoted fields).
std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (const char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

std::vector<CsvRow> ReadBenchCsv() {
  const char* path = std::getenv("RELUME_BENCH_CSV");
  if (!path) ADD_FAILURE() << "RELUME_BENCH_CSV is not set";
  std::ifstream in(path ? path : "");
  std::vector<CsvRow> rows;
  std::string line;
  if (!std::getline(in, line)) {
    ADD_FAILURE() << "cannot read " << (path ? path : "(null)");
    return rows;
  }
  const std::vector<std::string> header = SplitCsv(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> values = SplitCsv(line);
    EXPECT_EQ(values.size(), header.size()) << line;
    CsvRow row;
    for (std::size_t i = 0; i < header.size() && i < values.size(); ++i) row.field[header[i]] = values[i];
    rows.push_back(row);
  }
  return rows;
}

TEST(BenchCsvTest, EveryStageHasFinitePositiveTimesAndFiniteErrors) {
  const std::vector<CsvRow> rows = ReadBenchCsv();
  std::map<std::string, int> per_stage;
  for (const CsvRow& r : rows) {
    const std::string what = r.field.at("stage") + " / " + r.field.at("method") + " / " + r.field.at("knobs");
    ++per_stage[r.field.at("stage")];
    const double seconds = r.Number("seconds"), error = r.Number("error");
    EXPECT_TRUE(std::isfinite(seconds) && seconds > 0.0) << what << ": " << seconds << " s";
    EXPECT_TRUE(std::isfinite(error) && error >= 0.0) << what << ": error " << error;
    EXPECT_FALSE(r.field.at("error_metric").empty()) << what;
  }
  for (const std::string stage : {"hdr", "hdr-merge", "sun", "sh", "irm", "radiosity", "planner"}) {
    EXPECT_GE(per_stage[stage], 2) << "stage " << stage << " missing or with one row only";
  }
}

// Times are reported, not asserted (speed belongs in the bench's numbers, and a 1.4x saving
// flips under a parallel ctest load): the bench itself throws when a skip did not apply (one
// planned exposure, a single IRM, order 1, radiosity skipped, the stage reused), so a row here
// means the skip was taken.
TEST(BenchCsvTest, EachPlannerSkipHasItsForcedRun) {
  const std::vector<CsvRow> rows = ReadBenchCsv();
  std::map<std::string, const CsvRow*> skip, forced;
  for (const CsvRow& r : rows) {
    if (r.field.at("stage") != "planner") continue;
    const std::string method = r.field.at("method");
    if (method.rfind("skip: ", 0) == 0) skip[method.substr(6)] = &r;
    if (method.rfind("forced: ", 0) == 0) forced[method.substr(8)] = &r;
  }
  const std::set<std::string> expected = {"single exposure instead of a merge",
                                          "one IRM instead of four (no cast shadow)",
                                          "SH order 1 instead of 2 (normals do not support 2)",
                                          "no depth filters (depth noise below 0.05 mm)",
                                          "no radiosity (indirect share below tolerance)",
                                          "reuse of an unchanged stage"};
  for (const std::string& name : expected) {
    ASSERT_TRUE(skip.count(name) && forced.count(name)) << "planner skip missing: " << name;
  }
  EXPECT_EQ(skip.size(), expected.size());
  for (const auto& [name, s] : skip) {
    ASSERT_TRUE(forced.count(name)) << name << " has no forced run";
    const double skip_s = s->Number("seconds"), forced_s = forced[name]->Number("seconds");
    EXPECT_TRUE(std::isfinite(s->Number("error")) && std::isfinite(forced[name]->Number("error"))) << name;
    EXPECT_NE(s->field.at("notes").find("saved"), std::string::npos) << name << ": the saving is not reported";
    std::printf("%s: %.4g s with the skip, %.4g s forced\n", name.c_str(), skip_s, forced_s);
  }
}

}  // namespace
