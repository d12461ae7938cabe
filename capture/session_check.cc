#include "capture/session_check.h"

#include <algorithm>
#include <map>
#include <set>
#include <sstream>

#include "capture/durable_file.h"
#include "capture/folder_lock.h"
#include "capture/path_policy.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "core/clock.h"
#include "core/error.h"

namespace relume::capture {

namespace fs = std::filesystem;

namespace {

bool IsTemp(const fs::path& path) {
  return path.string().ends_with(kTempSuffix);
}

// What lies under frames/ that no row names: regular files (debris or orphans) and entries that
// are not regular files at all (links, FIFOs, devices), which relume never wrote and never follows.
struct Unlisted {
  std::vector<fs::path> files;
  std::vector<fs::path> foreign;
};

Unlisted UnlistedEntries(const fs::path& dir, const std::set<std::string>& listed) {
  Unlisted unlisted;
  const fs::path frames = dir / "frames";
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(frames, ec))) return unlisted;
  for (auto it = fs::recursive_directory_iterator(frames); it != fs::recursive_directory_iterator(); ++it) {
    const fs::file_status status = it->symlink_status();
    if (fs::is_directory(status)) continue;  // the iterator does not descend into linked folders
    const std::string relative = it->path().lexically_relative(dir).generic_string();
    if (listed.contains(relative)) continue;
    (fs::is_regular_file(status) ? unlisted.files : unlisted.foreign).push_back(it->path());
  }
  std::sort(unlisted.files.begin(), unlisted.files.end());
  std::sort(unlisted.foreign.begin(), unlisted.foreign.end());
  return unlisted;
}

std::string Relative(const fs::path& path, const fs::path& dir) {
  return path.lexically_relative(dir).generic_string();
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
  if (unsafe_paths > 0) out << ", " << unsafe_paths << " unreadable or unsafe frame paths";
  if (foreign_entries > 0) out << ", " << foreign_entries << " foreign entries under frames/";
  for (const std::string& p : problems) out << "\n  " << p;
  if (!ok() && missing_files == 0 && checksum_mismatches == 0 && unsafe_paths == 0 && foreign_entries == 0) {
    out << "\n  run `relume session recover` to fix";
  }
  return out.str();
}

namespace {

// Checks one frame's file: inside the session, a regular file, its SHA-256 as recorded.
void VerifyFrame(const fs::path& dir, const FrameRecord& frame, VerifyReport& report) {
  const std::string name = "frame " + std::to_string(frame.id);
  if (const std::optional<std::string> problem = SessionPathProblem(dir, frame.file_path)) {
    ++report.unsafe_paths;
    report.problems.push_back(name + ": " + *problem + " (not read: relume reads only files inside the session)");
    return;
  }
  const fs::path path = dir / frame.file_path;
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(path, ec))) {
    ++report.missing_files;
    report.problems.push_back(name + ": file " + frame.file_path + " is missing");
    return;
  }
  try {
    if (Sha256HexOfRegularFile(path) != frame.sha256) {
      ++report.checksum_mismatches;
      report.problems.push_back(name + ": " + frame.file_path + " does not match its recorded SHA-256");
    }
  } catch (const IoError& e) {
    ++report.unsafe_paths;
    report.problems.push_back(name + ": " + e.what());
  }
}

}  // namespace

VerifyReport VerifySession(const fs::path& dir) {
  const SessionReader reader(dir);
  VerifyReport report;
  const std::vector<FrameRecord> frames = reader.Frames();
  for (const FrameRecord& frame : frames) {
    ++report.frames_checked;
    VerifyFrame(dir, frame, report);
  }
  const Unlisted unlisted = UnlistedEntries(dir, ListedFiles(frames));
  for (const fs::path& path : unlisted.files) {
    if (IsTemp(path)) {
      ++report.temp_files;
      report.problems.push_back("temporary file of an interrupted write: " + Relative(path, dir));
    } else {
      ++report.orphan_files;
      report.problems.push_back("file without a row (never acknowledged): " + Relative(path, dir));
    }
  }
  for (const fs::path& path : unlisted.foreign) {
    ++report.foreign_entries;
    report.problems.push_back("not a regular file (a link, FIFO or device relume never writes): " +
                              Relative(path, dir) + "; remove it by hand");
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
  if (foreign_left > 0) out << ", " << foreign_left << " foreign entries left in place";
  for (const std::string& a : actions) out << "\n  " << a;
  return out.str();
}

namespace {

// A name under orphans/ for an unacknowledged file that no earlier orphan has: an orphan is kept,
// never overwritten.
fs::path FreeOrphanPath(const fs::path& dir, const fs::path& file) {
  const fs::path target = dir / "orphans" / file.lexically_relative(dir / "frames");
  fs::path candidate = target;
  std::error_code ec;
  for (int n = 1; fs::exists(fs::symlink_status(candidate, ec)); ++n) {
    candidate = target.parent_path() / (target.filename().string() + '.' + std::to_string(n));
  }
  return candidate;
}

}  // namespace

RecoverReport RecoverSession(const fs::path& dir) {
  RecoverReport report;
  const FolderLock lock = FolderLock::Acquire(dir, "session recover");
  std::vector<BracketRecord> brackets;
  std::vector<FrameRecord> frames;
  {
    const SessionReader reader(dir);
    frames = reader.Frames();
    brackets = reader.Brackets();
  }
  const Unlisted unlisted = UnlistedEntries(dir, ListedFiles(frames));
  for (const fs::path& path : unlisted.files) {
    const std::string relative = Relative(path, dir);
    if (IsTemp(path)) {
      fs::remove(path);
      ++report.temp_files_removed;
      report.actions.push_back("removed " + relative + " (an interrupted write; never acknowledged)");
    } else {
      const fs::path target = FreeOrphanPath(dir, path);
      CreateDirectoryDurably(target.parent_path());
      fs::rename(path, target);
      SyncDirectory(target.parent_path());
      SyncDirectory(path.parent_path());
      ++report.orphans_kept;
      report.actions.push_back("moved " + relative + " to " + Relative(target, dir) +
                               " (written but never acknowledged)");
    }
  }
  for (const fs::path& path : unlisted.foreign) {
    ++report.foreign_left;
    report.actions.push_back("left " + Relative(path, dir) +
                             " alone: it is not a regular file (a link, FIFO or device relume never writes); "
                             "remove it by hand");
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
    if (!SessionPathProblem(dir, f.file_path)) bytes += fs::file_size(dir / f.file_path, error);
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
  const std::vector<CalibrationRecord> calibrations = reader.Calibrations();
  std::map<std::string, int> kinds;
  for (const CalibrationRecord& c : calibrations) ++kinds[c.kind];
  out << "\ncalibrations  " << calibrations.size();
  for (const auto& [kind, count] : kinds) out << (kind == kinds.begin()->first ? " (" : ", ") << count << " " << kind;
  out << (kinds.empty() ? "" : ")") << "\n";
  // The scene processing will use (core/scene_model.h): the latest scene_model row.
  if (const CalibrationRecord* row = LatestSceneModelRow(calibrations)) {
    const std::string what = "calibration row " + std::to_string(row->id);
    try {
      const SceneModel model = SceneModelFromJson(row->json, what);
      out << "scene model   " << DescribeSceneModel(model) << " (" << what << ", from " << model.source << ")\n";
      for (const SceneModelCamera& c : model.cameras) {
        const Eigen::Vector3d eye = c.camera.world_from_camera.translation();
        const Eigen::Vector3d axis = c.camera.world_from_camera.linear().col(2);
        out << "  camera " << c.device_id << ": " << c.camera.intrinsics.width << "x" << c.camera.intrinsics.height
            << ", fx " << c.camera.intrinsics.fx << " px, at (" << eye.x() << ", " << eye.y() << ", " << eye.z()
            << ") m ENU looking (" << axis.x() << ", " << axis.y() << ", " << axis.z() << ")"
            << (c.distortion.empty() ? "" : ", with distortion") << "\n";
      }
    } catch (const Error& e) {
      out << "scene model   unreadable: " << e.what() << "\n";
    }
  } else {
    out << "scene model   none (processing that needs camera poses or geometry will say what to add)\n";
  }
  return out.str();
}

}  // namespace relume::capture
