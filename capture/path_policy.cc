#include "capture/path_policy.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "capture/file_descriptor.h"
#include "capture/session.h"
#include "core/error.h"

namespace relume::capture {

namespace fs = std::filesystem;

namespace {

// "a FIFO", "a directory", ... for a stat mode that is not a regular file.
std::string KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a regular file";
}

// Opens a regular file for reading, never through a final link, never blocking on a FIFO.
FileDescriptor OpenRegularFile(const fs::path& path) {
  FileDescriptor file(::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
  if (file.get() < 0) {
    const int error = errno;
    if (error == ENOENT) throw IoError(path.string(), "is missing");
    if (error == ELOOP) throw IoError(path.string(), "is a symbolic link; relume reads only regular files here");
    throw IoError(path.string(), std::string("cannot open: ") + std::strerror(error));
  }
  struct stat status {};
  if (::fstat(file.get(), &status) != 0)
    throw IoError(path.string(), std::string("cannot stat: ") + std::strerror(errno));
  if (!S_ISREG(status.st_mode)) {
    throw IoError(path.string(), "is " + KindOf(status.st_mode) + ", not a regular file; relume reads only files here");
  }
  return file;
}

// The files and folders of a session that hold what it recorded.
bool IsSessionDataName(const std::string& name) {
  return name == "frames" || name == "orphans" || name == "rig" || name.starts_with(kSessionDatabaseName);
}

bool HoldsSession(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / kSessionDatabaseName, ec);
}

// The path made absolute with every existing link resolved (an output that does not exist yet
// keeps its missing tail as written).
fs::path Resolved(const fs::path& path) {
  std::error_code ec;
  fs::path resolved = fs::weakly_canonical(fs::absolute(path), ec);
  return ec ? fs::absolute(path).lexically_normal() : resolved;
}

}  // namespace

std::optional<std::string> SessionPathProblem(const fs::path& session_dir, const std::string& relative) {
  if (relative.empty()) return std::string("the stored file path is empty");
  if (relative.find('\0') != std::string::npos) return std::string("the stored file path holds a NUL character");
  const fs::path path(relative);
  if (path.has_root_path()) return "the stored file path '" + relative + "' is absolute";
  fs::path walked = session_dir;
  for (const fs::path& part : path) {
    if (part == "..") return "the stored file path '" + relative + "' climbs out of the session with '..'";
    if (part == "." || part.empty()) continue;
    walked /= part;
    struct stat status {};
    if (::lstat(walked.c_str(), &status) != 0) break;  // missing: the reader says so
    if (S_ISLNK(status.st_mode)) {
      return "the stored file path '" + relative + "' passes through a symbolic link (" +
             walked.lexically_relative(session_dir).generic_string() + ")";
    }
  }
  return std::nullopt;
}

fs::path SessionFilePath(const fs::path& session_dir, const std::string& relative, const std::string& what) {
  if (const std::optional<std::string> problem = SessionPathProblem(session_dir, relative)) {
    throw IoError(session_dir.string(), what + ": " + *problem +
                                            "; relume reads only files inside the session (the database was edited "
                                            "or damaged: run `relume session verify`)");
  }
  return session_dir / relative;
}

std::vector<std::uint8_t> ReadRegularFile(const fs::path& path) {
  std::vector<std::uint8_t> bytes;
  ReadRegularFileBlocks(
      path, [&](std::span<const std::uint8_t> block) { bytes.insert(bytes.end(), block.begin(), block.end()); });
  return bytes;
}

void ReadRegularFileBlocks(const fs::path& path, const std::function<void(std::span<const std::uint8_t>)>& consume) {
  const FileDescriptor file = OpenRegularFile(path);
  std::vector<std::uint8_t> buffer(1 << 20);
  for (;;) {
    const ssize_t n = ::read(file.get(), buffer.data(), buffer.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(path.string(), std::string("read error: ") + std::strerror(errno));
    }
    if (n == 0) return;
    consume(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)));
  }
}

bool IsInsideSessionData(const fs::path& path, fs::path* session_dir) {
  const fs::path resolved = Resolved(path);
  for (fs::path dir = resolved.parent_path();; dir = dir.parent_path()) {
    if (HoldsSession(dir)) {
      const fs::path relative = resolved.lexically_relative(dir);
      if (!relative.empty() && IsSessionDataName(relative.begin()->string())) {
        if (session_dir) *session_dir = dir;
        return true;
      }
    }
    if (dir == dir.parent_path()) return false;
  }
}

void CheckOutputFile(const fs::path& output, const std::vector<fs::path>& inputs, const std::string& flag) {
  std::error_code ec;
  if (fs::exists(output, ec)) {
    for (const fs::path& input : inputs) {
      if (fs::equivalent(output, input, ec)) {
        throw InvalidArgumentError(flag + " " + output.string() + " is the input " + input.string() +
                                   "; relume never overwrites its inputs: name another output file");
      }
    }
  }
  fs::path session;
  if (IsInsideSessionData(output, &session)) {
    throw InvalidArgumentError(flag + " " + output.string() + " lies inside the recorded data of the session " +
                               session.string() + "; write outputs outside frames/, orphans/ and rig/");
  }
}

void CheckOutputFolder(const fs::path& folder, const std::string& flag) {
  if (HoldsSession(Resolved(folder))) {
    throw InvalidArgumentError(flag + " " + folder.string() +
                               " is a session folder; name a folder for the results (e.g. SESSION/processed)");
  }
  fs::path session;
  if (IsInsideSessionData(folder, &session)) {
    throw InvalidArgumentError(flag + " " + folder.string() + " lies inside the recorded data of the session " +
                               session.string() + "; write outputs outside frames/, orphans/ and rig/");
  }
}

}  // namespace relume::capture
