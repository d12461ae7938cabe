#include "capture/durable_file.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <vector>

#include "capture/file_descriptor.h"
#include "capture/path_policy.h"
#include "core/error.h"

namespace relume::capture {

namespace {

[[noreturn]] void ThrowErrno(const std::filesystem::path& path, const std::string& what, int error) {
  std::string message = what + ": " + std::strerror(error);
  if (error == ENOSPC || error == EDQUOT || error == EFBIG) {
    message += " (the disk is full: free space or choose another --out folder; frames already acknowledged are safe)";
  } else if (error == EACCES || error == EPERM || error == EROFS) {
    message += " (the folder is not writable: check its permissions or choose another --out folder)";
  }
  throw IoError(path.string(), message);
}

}  // namespace

void SyncDirectory(const std::filesystem::path& dir) {
  FileDescriptor fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.get() < 0) ThrowErrno(dir, "cannot open folder to sync it", errno);
  if (::fsync(fd.get()) != 0) ThrowErrno(dir, "cannot sync folder", errno);
}

void CreateDirectoryDurably(const std::filesystem::path& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) ThrowErrno(dir, "cannot create folder", error.value());
  SyncDirectory(dir);
  if (dir.has_parent_path()) SyncDirectory(dir.parent_path());
}

void WriteFileDurably(const std::filesystem::path& path, std::span<const std::uint8_t> bytes, bool sync_folder) {
  const std::filesystem::path temp = path.string() + kTempSuffix;
  FileDescriptor fd(::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (fd.get() < 0) ThrowErrno(temp, "cannot create file", errno);
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd.get(), bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::unlink(temp.c_str());
      ThrowErrno(temp, "cannot write file", error);
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd.get()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    ThrowErrno(temp, "cannot sync file", error);
  }
  if (::close(fd.release()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    ThrowErrno(temp, "cannot close file", error);
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    ThrowErrno(path, "cannot rename file into place", error);
  }
  if (sync_folder) SyncDirectory(path.parent_path());
}

namespace {
std::string Hex(const unsigned char* digest, unsigned int length) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(length * 2);
  for (unsigned int i = 0; i < length; ++i) {
    hex.push_back(kDigits[digest[i] >> 4]);
    hex.push_back(kDigits[digest[i] & 15]);
  }
  return hex;
}

struct DigestContext {
  DigestContext() : ctx(EVP_MD_CTX_new()) {
    RELUME_CHECK(ctx != nullptr && EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1);
  }
  ~DigestContext() { EVP_MD_CTX_free(ctx); }
  void Update(const void* data, std::size_t size) { RELUME_CHECK(EVP_DigestUpdate(ctx, data, size) == 1); }
  std::string Finish() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    RELUME_CHECK(EVP_DigestFinal_ex(ctx, digest, &length) == 1);
    return Hex(digest, length);
  }
  EVP_MD_CTX* ctx;
};
}  // namespace

std::string Sha256Hex(std::span<const std::uint8_t> bytes) {
  DigestContext digest;
  digest.Update(bytes.data(), bytes.size());
  return digest.Finish();
}

std::string Sha256HexOfFile(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw IoError(path.string(), "cannot open file to checksum it");
  DigestContext digest;
  std::vector<char> buffer(1 << 20);
  while (file) {
    file.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    digest.Update(buffer.data(), static_cast<std::size_t>(file.gcount()));
  }
  if (file.bad()) throw IoError(path.string(), "read error while checksumming");
  return digest.Finish();
}

std::string Sha256HexOfRegularFile(const std::filesystem::path& path) {
  DigestContext digest;
  ReadRegularFileBlocks(path, [&](std::span<const std::uint8_t> block) { digest.Update(block.data(), block.size()); });
  return digest.Finish();
}

}  // namespace relume::capture
