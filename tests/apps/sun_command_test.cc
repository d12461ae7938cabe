#include "apps/relume/sun_command.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"

namespace relume::app {
namespace {

SunQuery PaperQuery() {
  SunQuery query;
  query.latitude_deg = 39.742476;
  query.longitude_deg = -105.1786;
  query.height_m = 1830.14;
  query.time = "2003-10-17T12:30:30-07:00";
  query.options.pressure_hpa = 820;
  query.options.temperature_c = 11;
  query.options.delta_t_s = 67;
  return query;
}

TEST(SunCommandTest, JsonReportHasThePaperValues) {
  SunQuery query = PaperQuery();
  query.json = true;
  std::ostringstream out;
  RunSunSingle(query, out);
  const nlohmann::json j = nlohmann::json::parse(out.str());
  EXPECT_NEAR(j["zenith_deg"].get<double>(), 50.11162, 1e-5);
  EXPECT_NEAR(j["azimuth_deg"].get<double>(), 194.34024, 1e-5);
  EXPECT_EQ(j["day"]["sunrise"].get<std::string>(), "2003-10-17T06:12:43-07:00");
  EXPECT_EQ(j["day"]["kind"].get<std::string>(), "normal");
  EXPECT_EQ(j["delta_t_source"].get<std::string>(), "given");
}

TEST(SunCommandTest, MissingFlagsAreNamed) {
  SunQuery query = PaperQuery();
  query.time.reset();
  std::ostringstream out;
  EXPECT_THROW(RunSunSingle(query, out), InvalidArgumentError);
  query = PaperQuery();
  query.latitude_deg.reset();
  try {
    RunSunSingle(query, out);
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("--lat"), std::string::npos);
  }
}

TEST(SunCommandTest, CsvColumnsOverrideFlags) {
  SunQuery query = PaperQuery();
  std::istringstream in(
      "time,lat,temperature\n"
      "2003-10-17T12:30:30-07:00,,11\n"
      "\n"
      "2003-10-17T19:30:30Z,39.742476,\n");
  std::ostringstream out;
  EXPECT_EQ(RunSunCsv(query, in, "in.csv", out), 2u);
  std::istringstream lines(out.str());
  std::string header, row1, row2;
  std::getline(lines, header);
  std::getline(lines, row1);
  std::getline(lines, row2);
  EXPECT_EQ(header.substr(0, 30), "time,latitude_deg,longitude_de");
  EXPECT_EQ(row1, row2);  // the same instant and site, written two ways
  EXPECT_NE(row1.find(",194.34024"), std::string::npos) << row1;
  EXPECT_NE(row1.find(",50.11162"), std::string::npos) << row1;
}

TEST(SunCommandTest, CsvErrorsNameTheLine) {
  SunQuery query = PaperQuery();
  auto error_of = [&](const std::string& csv) {
    std::istringstream in(csv);
    std::ostringstream out;
    try {
      RunSunCsv(query, in, "obs.csv", out);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("time,lat\n2024-01-01T00:00:00Z,12\n2024-01-01T00:00:00Z,abc\n"),
            "obs.csv:3: lat: 'abc' is not a finite number");
  EXPECT_EQ(error_of("time,lat\n2024-01-01T00:00:00Z,95\n").substr(0, 16), "obs.csv:2: site:");
  EXPECT_NE(error_of("time\n2024-01-01T00:00:00\n").find("obs.csv:2: invalid ISO 8601"), std::string::npos);
  EXPECT_NE(error_of("when,lat\n").find("obs.csv:1: time:"), std::string::npos);
  EXPECT_NE(error_of("").find("empty CSV"), std::string::npos);
  query.latitude_deg.reset();
  EXPECT_NE(error_of("time,lon\n2024-01-01T00:00:00Z,1\n").find("lat/lon"), std::string::npos);
}

TEST(SunCommandTest, CsvMatchesSingleCallsAcrossSites) {
  SunQuery query;
  query.options.delta_t_s = 69;
  std::ostringstream csv;
  csv << "time,lat,lon,height\n";
  for (int i = 0; i < 50; ++i) {
    csv << "2025-03-20T" << (i % 24 < 10 ? "0" : "") << i % 24 << ":17:00Z," << (i * 3.6 - 88) << "," << (i * 7.1 - 179)
        << "," << i * 10 << "\n";
  }
  std::istringstream in(csv.str());
  std::ostringstream out;
  ASSERT_EQ(RunSunCsv(query, in, "sites.csv", out), 50u);
  std::istringstream lines(out.str());
  std::string line;
  std::getline(lines, line);
  for (int i = 0; i < 50; ++i) {
    std::getline(lines, line);
    const double elevation =
        std::stod(line.substr(line.find(',', line.find(',', line.find(',', line.find(',') + 1) + 1) + 1) + 1));
    char time[32];
    std::snprintf(time, sizeof(time), "2025-03-20T%02d:17:00Z", i % 24);
    const SunPosition expected = ComputeSunPosition(Site::FromDegrees(i * 3.6 - 88, i * 7.1 - 179, i * 10),
                                                    ParseIso8601(time).utc, query.options);
    EXPECT_NEAR(elevation, RadToDeg(expected.elevation_rad), 2e-6) << line;
  }
}

TEST(SunCommandTest, SeriesMatchesSingleCalls) {
  SunQuery query = PaperQuery();
  query.time = "2003-10-17T00:00:00-07:00";
  query.until = "2003-10-18T00:00:00-07:00";
  query.step_s = 600;
  std::ostringstream out;
  ASSERT_EQ(RunSunSeries(query, out), 145u);
  std::istringstream lines(out.str());
  std::string line;
  std::getline(lines, line);
  for (int i = 0; std::getline(lines, line); ++i) {
    std::vector<double> values;
    std::stringstream row(line.substr(line.find(',') + 1));
    for (std::string cell; std::getline(row, cell, ',');) values.push_back(std::stod(cell));
    const UtcTime t = ParseIso8601(*query.time).utc + std::chrono::minutes(10 * i);
    const SunPosition expected = ComputeSunPosition(Site::FromDegrees(39.742476, -105.1786, 1830.14), t, query.options);
    EXPECT_NEAR(values[3], RadToDeg(expected.elevation_rad), 2e-6);
    EXPECT_NEAR(values[4], RadToDeg(expected.azimuth_rad), 2e-6);
  }
  query.step_s = 0;
  EXPECT_THROW(RunSunSeries(query, out), InvalidArgumentError);
  query.step_s = 60;
  query.until = "2003-10-16T00:00:00Z";
  EXPECT_THROW(RunSunSeries(query, out), InvalidArgumentError);
}

}  // namespace
}  // namespace relume::app
