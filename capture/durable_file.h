// Crash-safe file writing: write to a temporary name in the destination folder, fsync, rename
// over the final name, fsync the folder. After WriteFileDurably returns, the file exists under
// its final name with its full contents even if the process is killed or the power fails.
// A crash before that leaves at most a "*.tmp" file, which `relume session recover` removes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

namespace relume::capture {

inline constexpr const char* kTempSuffix = ".tmp";

// Throws IoError naming the path (and "disk full" for ENOSPC / EDQUOT). With sync_folder false
// the folder is not fsynced: the caller must SyncDirectory(path.parent_path()) before anything
// relies on the file being there (writers of several files in one folder sync it once).
void WriteFileDurably(const std::filesystem::path& path, std::span<const std::uint8_t> bytes, bool sync_folder = true);
// fsyncs a directory so that a rename or new entry in it is durable.
void SyncDirectory(const std::filesystem::path& dir);
// Creates a directory (and parents) and makes its entry durable.
void CreateDirectoryDurably(const std::filesystem::path& dir);

// SHA-256 of bytes and of a file, as 64 lowercase hex digits.
std::string Sha256Hex(std::span<const std::uint8_t> bytes);
std::string Sha256HexOfFile(const std::filesystem::path& path);
// The same for a file relume reads from a session: only a regular file, never through a final
// symbolic link, never blocking on a FIFO (capture/path_policy.h); IoError otherwise.
std::string Sha256HexOfRegularFile(const std::filesystem::path& path);

}  // namespace relume::capture
