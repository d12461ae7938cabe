#include "capture/sqlite.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <optional>

#include "core/error.h"

namespace relume::capture {

namespace {

// Opens with `flags`; returns SQLite's message on failure (db is then null).
std::optional<std::string> Open(const std::string& name, int flags, sqlite3** db) {
  if (sqlite3_open_v2(name.c_str(), db, flags, nullptr) == SQLITE_OK) return std::nullopt;
  std::string message = *db ? sqlite3_errmsg(*db) : "out of memory";
  sqlite3_close(*db);
  *db = nullptr;
  return message;
}

// A read-only connection to a WAL database needs its -shm file; in a read-only folder without
// one the first read fails. True when a read works.
bool CanRead(sqlite3* db) {
  return sqlite3_exec(db, "SELECT count(*) FROM sqlite_master", nullptr, nullptr, nullptr) == SQLITE_OK;
}

bool FolderWritable(const std::string& path) {
  const std::filesystem::path folder = std::filesystem::absolute(path).parent_path();
  return ::access(folder.c_str(), W_OK) == 0;
}

// SQLite URI of a path (file:...), with the characters URIs reserve escaped.
std::string FileUri(const std::string& path) {
  std::string uri = "file:";
  for (char c : path) {
    if (c == '%' || c == '?' || c == '#') {
      static const char kHex[] = "0123456789ABCDEF";
      uri += '%';
      uri += kHex[(static_cast<unsigned char>(c) >> 4) & 15];
      uri += kHex[static_cast<unsigned char>(c) & 15];
    } else {
      uri += c;
    }
  }
  return uri;
}

}  // namespace

Database::Database(const std::string& path, Mode mode) : path_(path) {
  int flags = SQLITE_OPEN_FULLMUTEX;
  if (mode == Mode::kReadOnly) {
    flags |= SQLITE_OPEN_READONLY;
  } else {
    flags |= SQLITE_OPEN_READWRITE | (mode == Mode::kCreate ? SQLITE_OPEN_CREATE : 0);
  }
  std::optional<std::string> failure = Open(path, flags, &db_);
  if (!failure) sqlite3_busy_timeout(db_, 5000);
  if (!failure && mode == Mode::kReadOnly && !FolderWritable(path) && !CanRead(db_)) {
    // A read-only folder: nothing can change the file while we read it, so immutable is exact.
    sqlite3_close(db_);
    db_ = nullptr;
    failure = Open(FileUri(path) + "?immutable=1", flags | SQLITE_OPEN_URI, &db_);
  }
  if (failure) throw IoError(path, "cannot open the session database: " + *failure);
  sqlite3_busy_timeout(db_, 5000);
  sqlite3_extended_result_codes(db_, 1);
}

Database::~Database() {
  sqlite3_close(db_);
}

void Database::Fail(const std::string& what) const {
  const int code = sqlite3_extended_errcode(db_);
  std::string message = what + ": " + sqlite3_errmsg(db_);
  if ((code & 0xff) == SQLITE_FULL) message += " (the disk is full: free space, then run `relume session recover`)";
  throw IoError(path_, message);
}

void Database::Exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    Fail("SQL failed (" + sql.substr(0, 60) + "): " + message);
  }
}

Statement Database::Prepare(const std::string& sql) {
  return Statement(*this, sql);
}

std::int64_t Database::LastInsertId() const {
  return sqlite3_last_insert_rowid(db_);
}

Statement::Statement(Database& db, const std::string& sql) : db_(&db) {
  if (sqlite3_prepare_v2(db.db_, sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
    db.Fail("cannot prepare SQL (" + sql.substr(0, 60) + ")");
  }
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

Statement::Statement(Statement&& other) noexcept : db_(other.db_), stmt_(other.stmt_) {
  other.stmt_ = nullptr;
}

Statement& Statement::Bind(int index, std::int64_t value) {
  if (sqlite3_bind_int64(stmt_, index, value) != SQLITE_OK) db_->Fail("bind failed");
  return *this;
}

Statement& Statement::Bind(int index, double value) {
  if (std::isnan(value)) return BindNull(index);
  if (sqlite3_bind_double(stmt_, index, value) != SQLITE_OK) db_->Fail("bind failed");
  return *this;
}

Statement& Statement::Bind(int index, const std::string& value) {
  if (sqlite3_bind_text(stmt_, index, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT) != SQLITE_OK) {
    db_->Fail("bind failed");
  }
  return *this;
}

Statement& Statement::BindNull(int index) {
  if (sqlite3_bind_null(stmt_, index) != SQLITE_OK) db_->Fail("bind failed");
  return *this;
}

bool Statement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_->Fail("SQL step failed");
}

void Statement::Run() {
  while (Step()) {
  }
  Reset();
}

void Statement::Reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

bool Statement::IsNull(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}
std::int64_t Statement::Int(int column) const {
  return sqlite3_column_int64(stmt_, column);
}
double Statement::Double(int column) const {
  return IsNull(column) ? NAN : sqlite3_column_double(stmt_, column);
}
std::string Statement::Text(int column) const {
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  return text ? std::string(reinterpret_cast<const char*>(text),
                            static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column)))
              : std::string();
}

Transaction::Transaction(Database& db) : db_(db) {
  db_.Exec("BEGIN IMMEDIATE");
}

Transaction::~Transaction() {
  if (!done_) {
    char* error = nullptr;
    sqlite3_exec(db_.db_, "ROLLBACK", nullptr, nullptr, &error);
    sqlite3_free(error);
  }
}

void Transaction::Commit() {
  db_.Exec("COMMIT");
  done_ = true;
}

}  // namespace relume::capture
