// `relume session verify | recover | info`: checking a session on disk, making a session that
// stopped mid-write consistent again, and summarising it.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace relume::capture {

struct VerifyReport {
  int frames_checked = 0;
  int missing_files = 0;
  int checksum_mismatches = 0;
  int orphan_files = 0;  // complete files under frames/ without a row (never acknowledged)
  int temp_files = 0;    // *.tmp debris of an interrupted write
  int open_brackets = 0;
  int unsafe_paths = 0;               // rows whose file lies outside the session or is not a regular file (not read)
  int foreign_entries = 0;            // links, FIFOs, devices under frames/ (relume never writes them)
  std::vector<std::string> problems;  // one line per problem, naming the file or row
  bool ok() const {
    return missing_files == 0 && checksum_mismatches == 0 && orphan_files == 0 && temp_files == 0 &&
           open_brackets == 0 && unsafe_paths == 0 && foreign_entries == 0;
  }
  std::string Summary() const;
};

// Reads every frame file and compares its SHA-256 with its row; looks for debris. Reads only
// files inside the session (capture/path_policy.h): a row naming a path outside it, or a file
// that is a link, FIFO or device, is a problem reported, never read.
VerifyReport VerifySession(const std::filesystem::path& dir);

struct RecoverReport {
  int temp_files_removed = 0;
  int orphans_kept = 0;  // moved to orphans/ (kept, never deleted)
  int brackets_closed = 0;
  int foreign_left = 0;              // links, FIFOs, devices under frames/: reported, never followed or moved
  std::vector<std::string> actions;  // what was done, one line each
  std::string Summary() const;
};

// Makes a session consistent after a crash: removes *.tmp files, moves complete files without
// a row to orphans/, marks open brackets "partial", checkpoints the WAL, and records what it
// did as a session event. Acknowledged frames are never touched; nothing under frames/ that is not
// a regular file is followed or moved. Holds the session's lock (capture/folder_lock.h).
RecoverReport RecoverSession(const std::filesystem::path& dir);

// A human-readable summary: devices, frames per stream, time span, sun elevation range,
// brackets, events by type, disk use.
std::string DescribeSession(const std::filesystem::path& dir);

}  // namespace relume::capture
