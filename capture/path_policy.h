// Where relume may read and write, in one place.
//
// Reading: every path a session's database names (a frame's file) resolves inside the session
// folder: relative, no `..`, no symbolic link on the way (the session folder itself may be
// reached through one), and a regular file. Files are opened with O_NOFOLLOW | O_NONBLOCK and
// checked with fstat, so a FIFO, a device or a link swapped in under frames/ is refused instead
// of hanging the reader or leading it outside the session.
//
// Writing: an output path is refused when it is one of the command's inputs (the same file,
// through any link) or lies inside a session's recorded data (frames/, orphans/, rig/ or the
// database itself) of any session above it.
//
// Every refusal is an IoError or InvalidArgumentError naming the path and what to do.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace relume::capture {

// The path of a file a session's database names (`relative`, as stored), checked to lie inside
// `session_dir`. Throws IoError naming the row's path when it is empty, absolute, climbs out
// with `..`, or passes through a symbolic link; `what` names the row in the message
// ("frame 12"). Does not require the file to exist.
std::filesystem::path SessionFilePath(const std::filesystem::path& session_dir, const std::string& relative,
                                      const std::string& what);

// Why `relative` is not an acceptable session path, or nullopt when it is (the check behind
// SessionFilePath, for callers that report instead of throwing).
std::optional<std::string> SessionPathProblem(const std::filesystem::path& session_dir, const std::string& relative);

// Reads a whole regular file without following a final symbolic link and without blocking on a
// FIFO or device. Throws IoError: "is missing" (ENOENT), "is a symbolic link", "is not a regular
// file (a FIFO/directory/device)", or the system's message.
std::vector<std::uint8_t> ReadRegularFile(const std::filesystem::path& path);

// The same checks, streaming the file through `consume` in blocks (for checksums of large files).
void ReadRegularFileBlocks(const std::filesystem::path& path,
                           const std::function<void(std::span<const std::uint8_t>)>& consume);

// True when `path` (or an ancestor) lies inside a session's recorded data: the folders frames/,
// orphans/ and rig/ or the database file of a folder holding session.sqlite. `session_dir` is
// set to that session when given.
bool IsInsideSessionData(const std::filesystem::path& path, std::filesystem::path* session_dir = nullptr);

// Refuses an output file: InvalidArgumentError naming `flag` when `output` is the same file as
// any of `inputs` (compared after resolving links, so a link to an input counts), or lies inside
// a session's recorded data.
void CheckOutputFile(const std::filesystem::path& output, const std::vector<std::filesystem::path>& inputs,
                     const std::string& flag);

// Refuses an output folder inside a session's recorded data, or equal to a session folder itself
// (InvalidArgumentError naming `flag`).
void CheckOutputFolder(const std::filesystem::path& folder, const std::string& flag);

}  // namespace relume::capture
