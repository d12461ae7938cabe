#include "capture/session_check.h"

#include <algorithm>
#include <map>
#include <set>
#include <sstream>

#include "capture/durable_file.h"
#include "capture/session.h"
#include "core/clock.h"
#include "core/error.h"

namespace relume::capture {

namespace fs = std::filesystem;

namespace {

bool IsTemp(const fs::path& path) {
  return path.string().ends_with(kTempSuffix);
}

// Files under frames/ that no row names.
std::vector<fs::path> UnlistedFiles(const fs::path& dir, const std::set<std::string>& listed) {
  std::vector<fs::path> unlisted;
  const fs::path frames = dir / "frames";
  if (!fs::exists(frames)) return unlisted;
  for (const auto& entry : fs::recursive_directory_iterator(frames)) {
    if (!entry.is_regular_file()) continue;
    const std::string relative = fs::relative(entry.path(), dir).generic_string();
    if (!listed.contains(relative)) unlisted.push_back(entry.path());
  }
  std::sort(unlisted.begin(), unlisted.end());
  return unlisted;
}

std::set<std::string> ListedFiles(const std::vector<FrameRecord>& frames) {
  std::set<std::string> listed;
  for (const FrameRecord& f : frames) listed.insert(f.file_path);
  return listed;
}

}  // namespace

std::string VerifyReport::Summary() const {
  std::ostringstream out;
  out << (ok() ? "OK" : "PROBLEMS") << ": " << frames_checked << " frames checked, " << missing_files << " missing, "
      << checksum_mismatches << " checksum mismatches, " << orphan_files << " orphan files, " << temp_files
      << " temporary files, " << open_brackets << " open brackets";
  for (const std::string& p : problems) out << "\n  " << p;
  if (!ok() && missing_files == 0 && checksum_mismatches == 0) out << "\n  run `relume session recover` to fix";
  return out.str();
}

VerifyReport VerifySession(const fs::path& dir) {
  const SessionReader reader(dir);
  VerifyReport report;
  const std::vector<FrameRecord> frames = reader.Frames();
  for (const FrameRecord& frame : frames) {
    ++report.frames_checked;
    const fs::path path = dir / frame.file_path;
    if (!fs::exists(path)) {
      ++report.missing_files;
      report.problems.push_back("frame " + std::to_string(frame.id) + ": file " + frame.file_path + " is missing");
      continue;
    }
    if (Sha256HexOfFile(path) != frame.sha256) {
      ++report.checksum_mismatches;
      report.problems.push_back("frame " + std::to_string(frame.id) + ": " + frame.file_path +
                                " does not match its recorded SHA-256");
    }
  }
  for (const fs::path& path : UnlistedFiles(dir, ListedFiles(frames))) {
    if (IsTemp(path)) {
      ++report.temp_files;
      report.problems.push_back("temporary file of an interrupted write: " + fs::relative(path, dir).string());
    } else {
      ++report.orphan_files;
      report.problems.push_back("file without a row (never acknowledged): " + fs::relative(path, dir).string());
    }
  }
  for (const BracketRecord& bracket : reader.Brackets()) {
    if (bracket.status == "open") {
      ++report.open_brackets;
      report.problems.push_back("bracket " + std::to_string(bracket.id) + " of " + bracket.device_id +
                                " was never closed");
    }
  }
  return report;
}

std::string RecoverReport::Summary() const {
  std::ostringstream out;
  out << "recovered: " << temp_files_removed << " temporary files removed, " << orphans_kept
      << " unacknowledged files kept in orphans/, " << brackets_closed << " open brackets marked partial";
  for (const std::string& a : actions) out << "\n  " << a;
  return out.str();
}

RecoverReport RecoverSession(const fs::path& dir) {
  RecoverReport report;
  std::vector<BracketRecord> brackets;
  std::vector<FrameRecord> frames;
  {
    const SessionReader reader(dir);
    frames = reader.Frames();
    brackets = reader.Brackets();
  }
  for (const fs::path& path : UnlistedFiles(dir, ListedFiles(frames))) {
    const std::string relative = fs::relative(path, dir).generic_string();
    if (IsTemp(path)) {
      fs::remove(path);
      ++report.temp_files_removed;
      report.actions.push_back("removed " + relative + " (an interrupted write; never acknowledged)");
    } else {
      const fs::path target = dir / "orphans" / fs::relative(path, dir / "frames");
      CreateDirectoryDurably(target.parent_path());
      fs::rename(path, target);
      SyncDirectory(target.parent_path());
      SyncDirectory(path.parent_path());
      ++report.orphans_kept;
      report.actions.push_back("moved " + relative + " to " + fs::relative(target, dir).generic_string() +
                               " (written but never acknowledged)");
    }
  }
  auto writer = SessionWriter::Append(dir);
  for (const BracketRecord& bracket : brackets) {
    if (bracket.status != "open") continue;
    writer->EndBracket(bracket.id, "partial", "the session stopped before the bracket finished");
    ++report.brackets_closed;
    report.actions.push_back("bracket " + std::to_string(bracket.id) + " marked partial");
  }
  if (!report.actions.empty()) {
    SystemClock clock;
    std::string message = report.Summary();
    writer->AddEvent({0, clock.NowUtc(), clock.NowMonotonic(), "", "recover", message});
  }
  return report;
}

std::string DescribeSession(const fs::path& dir) {
  const SessionReader reader(dir);
  const SessionInfo& info = reader.info();
  std::ostringstream out;
  out << "session       " << info.name << "\n";
  out << "site          " << info.site.latitude_deg() << " deg N, " << info.site.longitude_deg() << " deg E, "
      << info.site.height_m << " m\n";
  out << "created       " << FormatIso8601(info.created_utc) << " (clock: " << info.clock_name << ")\n";
  out << "software      " << info.software_version << "\n";
  for (const drivers::DeviceInfo& d : reader.Devices()) {
    out << "device        " << d.FullId() << " (" << drivers::ToString(d.kind) << ", " << d.model << ")\n";
  }
  const std::vector<FrameRecord> frames = reader.Frames();
  std::map<std::string, int> per_stream;
  double min_elevation = 90.0, max_elevation = -90.0;
  std::uintmax_t bytes = 0;
  for (const FrameRecord& f : frames) {
    ++per_stream[f.device_id + " " + f.stream];
    min_elevation = std::min(min_elevation, f.sun_elevation_deg);
    max_elevation = std::max(max_elevation, f.sun_elevation_deg);
    std::error_code error;
    bytes += fs::file_size(dir / f.file_path, error);
  }
  out << "frames        " << frames.size();
  if (!frames.empty()) {
    out << " from " << FormatIso8601(frames.front().utc) << " to " << FormatIso8601(frames.back().utc)
        << ", sun elevation " << min_elevation << " .. " << max_elevation << " deg";
  }
  out << ", " << bytes / 1024 << " KiB\n";
  for (const auto& [stream, count] : per_stream) out << "  " << stream << ": " << count << "\n";
  std::map<std::string, int> bracket_status;
  for (const BracketRecord& b : reader.Brackets()) ++bracket_status[b.status];
  out << "brackets     ";
  for (const auto& [status, count] : bracket_status) out << " " << count << " " << status;
  out << "\n";
  std::map<std::string, int> event_types;
  for (const EventRecord& e : reader.Events()) ++event_types[e.type];
  out << "events       ";
  for (const auto& [type, count] : event_types) out << " " << count << " " << type;
  out << "\ncalibrations  " << reader.Calibrations().size() << "\n";
  return out.str();
}

}  // namespace relume::capture
