// A thin RAII layer over SQLite for the session store: errors become relume::IoError naming
// the database file and SQLite's message.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <optional>
#include <string>

namespace relume::capture {

class Statement;

class Database {
 public:
  enum class Mode {
    kReadWrite,  // an existing database
    kCreate,     // created when missing
    kReadOnly,   // never written: falls back to SQLite's immutable mode when the folder is
                 // read-only and the WAL's shared-memory file cannot be created
  };
  Database(const std::string& path, Mode mode);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  void Exec(const std::string& sql);
  Statement Prepare(const std::string& sql);
  std::int64_t LastInsertId() const;
  const std::string& path() const { return path_; }
  [[noreturn]] void Fail(const std::string& what) const;

 private:
  friend class Statement;
  friend class Transaction;
  sqlite3* db_ = nullptr;
  std::string path_;
};

class Statement {
 public:
  Statement(Database& db, const std::string& sql);
  ~Statement();
  Statement(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement& operator=(Statement&&) = delete;

  // Parameters are 1-based, as in SQLite. A nullopt binds NULL.
  Statement& Bind(int index, std::int64_t value);
  Statement& Bind(int index, double value);  // NaN binds NULL
  Statement& Bind(int index, const std::string& value);
  Statement& BindNull(int index);
  template <typename T>
  Statement& Bind(int index, const std::optional<T>& value) {
    return value ? Bind(index, *value) : BindNull(index);
  }
  // Steps once: true while a row is available.
  bool Step();
  // Runs to completion (for INSERT/UPDATE).
  void Run();
  void Reset();

  bool IsNull(int column) const;
  std::int64_t Int(int column) const;
  double Double(int column) const;  // NULL reads as NaN
  std::string Text(int column) const;

 private:
  Database* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN IMMEDIATE ... COMMIT, rolled back if not committed.
class Transaction {
 public:
  explicit Transaction(Database& db);
  ~Transaction();
  void Commit();

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace relume::capture
