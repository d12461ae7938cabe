#include "capture/folder_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>

#include "core/error.h"

namespace relume::capture {

namespace fs = std::filesystem;

struct FolderLock::Held {
  fs::path folder;
  fs::path key;   // the folder's canonical path, the registry's key
  pid_t pid = 0;  // the process that took it (a forked child inherits the registry, not the lock)
  int fd = -1;
  ~Held() {
    if (fd >= 0) ::close(fd);  // closing the last descriptor releases the flock
  }
};

namespace {

// The locks this process holds, by canonical folder; weak, so a lock ends with its last holder.
std::mutex registry_mutex;
std::map<fs::path, std::weak_ptr<FolderLock::Held>>& Registry() {
  static std::map<fs::path, std::weak_ptr<FolderLock::Held>> registry;
  return registry;
}

std::string ReadHolder(int fd) {
  char buffer[512];
  const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
  if (n <= 0) return "another relume process";
  std::string text(buffer, static_cast<std::size_t>(n));
  while (!text.empty() && (text.back() == '\n' || text.back() == '\0')) text.pop_back();
  return text.empty() ? "another relume process" : text;
}

}  // namespace

FolderLock FolderLock::Acquire(const fs::path& folder, const std::string& purpose) {
  std::error_code ec;
  const fs::path key = fs::canonical(folder, ec);
  if (ec) throw IoError(folder.string(), "cannot lock the folder: " + ec.message());
  std::lock_guard<std::mutex> guard(registry_mutex);
  if (std::shared_ptr<Held> held = Registry()[key].lock(); held && held->pid == ::getpid()) return FolderLock(held);

  auto held = std::make_shared<Held>();
  held->folder = folder;
  held->key = key;
  held->pid = ::getpid();
  const fs::path path = key / kLockFileName;
  held->fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (held->fd < 0) {
    const int error = errno;
    if (error == EROFS || error == EACCES || error == EPERM) {
      throw IoError(folder.string(), "is read-only, so relume cannot write here (" + std::string(std::strerror(error)) +
                                         "); read-only sessions can be verified, inspected and processed with "
                                         "--out into another folder");
    }
    throw IoError(path.string(), std::string("cannot create the lock file: ") + std::strerror(error));
  }
  if (::flock(held->fd, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    if (error == EWOULDBLOCK) {
      throw IoError(folder.string(), "is in use by " + ReadHolder(held->fd) +
                                         "; wait until it finishes (two writers at once would corrupt each "
                                         "other's results)");
    }
    throw IoError(path.string(), std::string("cannot lock: ") + std::strerror(error));
  }
  const std::string text = "pid " + std::to_string(::getpid()) + " (relume " + purpose + ")\n";
  if (::ftruncate(held->fd, 0) != 0 || ::pwrite(held->fd, text.data(), text.size(), 0) < 0) {
    // The lock holds without the note; only the message to a second writer is poorer.
  }
  Registry()[key] = held;
  return FolderLock(held);
}

FolderLock::~FolderLock() {
  if (!held_) return;
  std::lock_guard<std::mutex> guard(registry_mutex);
  if (held_.use_count() == 1) Registry().erase(held_->key);
  held_.reset();
}

const fs::path& FolderLock::folder() const {
  return held_->folder;
}

}  // namespace relume::capture
