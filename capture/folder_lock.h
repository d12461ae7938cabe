// An advisory lock on a folder for the processes that write into it: a session (capture,
// recover, calibrations stored into it) or a processing output folder (`relume process`).
//
// The lock is flock(2) on `<folder>/.relume.lock`, so the kernel releases it when its holder
// exits or is killed: a crashed writer never leaves a stale lock. The holder writes its pid and
// what it is doing into the file, and a second writer is refused with a message that names them.
// Within one process the lock is shared (counted): a command that holds a session's lock may
// open the session's writer, which takes the same lock again.
//
// Readers (verify, info, processing reading a session) take no lock: the session store is
// written so that a reader always sees acknowledged frames only.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

namespace relume::capture {

inline constexpr const char* kLockFileName = ".relume.lock";

class FolderLock {
 public:
  // Takes the lock on `folder` (which must exist), saying `purpose` ("capture", "process irm")
  // to anyone who finds it taken. Throws IoError naming the folder and the holder when another
  // process holds it, or when the folder cannot hold a lock file (read-only).
  static FolderLock Acquire(const std::filesystem::path& folder, const std::string& purpose);

  FolderLock(FolderLock&&) noexcept = default;
  FolderLock& operator=(FolderLock&&) noexcept = default;
  ~FolderLock();

  const std::filesystem::path& folder() const;

  struct Held;  // the open lock file, shared by every FolderLock of this process on the folder

 private:
  explicit FolderLock(std::shared_ptr<Held> held) : held_(std::move(held)) {}
  std::shared_ptr<Held> held_;
};

}  // namespace relume::capture
