// The study results database (study/results_db.hpp) on Debian's libsqlite3.
#include "study/results_db.hpp"

#include <sqlite3.h>

#include <chrono>
#include <ctime>
#include <stdexcept>

#include "study/study_file.hpp"

namespace twill {
namespace {

constexpr const char* kSchemaVersion = "1";

// How long a writer waits for another connection's lock (a `twill report` reading the file
// while the sweep writes) before SQLite reports it busy.
constexpr int kBusyTimeoutMs = 10000;

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs(
  hash TEXT PRIMARY KEY, command TEXT NOT NULL, dataset TEXT NOT NULL, run_order INTEGER NOT NULL,
  status TEXT NOT NULL CHECK(status IN ('running', 'done', 'failed')), exit_code INTEGER,
  error TEXT, wall_s REAL, started TEXT, finished TEXT, rank INTEGER, out_dir TEXT, config_yaml TEXT);
CREATE TABLE IF NOT EXISTS swept(hash TEXT NOT NULL REFERENCES runs(hash), key TEXT NOT NULL,
  value TEXT NOT NULL, PRIMARY KEY(hash, key));
CREATE TABLE IF NOT EXISTS metrics(hash TEXT NOT NULL REFERENCES runs(hash), name TEXT NOT NULL,
  value REAL, PRIMARY KEY(hash, name));
)sql";

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// One prepared statement; bind by 1-based index, step, finalize on destruction.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& file) : db_(db), file_(file) {
    check(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr), "prepare");
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int i, const std::string& text) {
    check(sqlite3_bind_text(stmt_, i, text.c_str(), static_cast<int>(text.size()), SQLITE_TRANSIENT), "bind");
    return *this;
  }
  Statement& bind(int i, double value) {
    check(sqlite3_bind_double(stmt_, i, value), "bind");
    return *this;
  }
  Statement& bind(int i, int value) {
    check(sqlite3_bind_int(stmt_, i, value), "bind");
    return *this;
  }
  /// True while a row is available.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    check(rc == SQLITE_DONE ? SQLITE_OK : rc, "step");
    return false;
  }
  void run() {
    while (step()) {
    }
    sqlite3_reset(stmt_);
  }
  std::string text(int column) const {
    const unsigned char* t = sqlite3_column_text(stmt_, column);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  int columns() const { return sqlite3_column_count(stmt_); }

 private:
  void check(int rc, const char* what) const {
    if (rc != SQLITE_OK)
      throw std::runtime_error(std::string("results database ") + file_ + ": " + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string file_;
};

}  // namespace

ResultsDb::ResultsDb(const std::filesystem::path& file, Access access) : file_(file.string()) {
  const bool create = access == Access::create;
  if (!create && !std::filesystem::is_regular_file(file))
    throw std::runtime_error("no results database " + file_ + " (twill sweep writes DIR/results.sqlite)");
  const int flags = create ? SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE : SQLITE_OPEN_READONLY;
  if (sqlite3_open_v2(file_.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error("cannot open the results database " + file_ + ": " + why);
  }
  sqlite3_busy_timeout(db_, kBusyTimeoutMs);
  try {
    if (create) execute(kSchema);
    check_schema(create);
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

void ResultsDb::check_schema(bool create) {
  std::vector<std::vector<std::string>> version;
  try {
    version = query("SELECT value FROM meta WHERE key = 'schema_version'");
  } catch (const std::runtime_error&) {
    throw std::runtime_error(file_ + " is not a twill results database (no meta table)");
  }
  if (version.empty() && create)
    Statement(db_, "INSERT INTO meta(key, value) VALUES('schema_version', ?)", file_).bind(1, kSchemaVersion).run();
  else if (version.empty() || version[0][0] != kSchemaVersion)
    throw std::runtime_error("results database " + file_ + " has schema version " +
                             (version.empty() ? std::string("(none)") : version[0][0]) + "; this twill reads version " +
                             kSchemaVersion + (create ? " (use a new output folder)" : ""));
}

std::optional<std::string> ResultsDb::meta(const std::string& key) const {
  Statement s(db_, "SELECT value FROM meta WHERE key = ?", file_);
  s.bind(1, key);
  if (!s.step()) return std::nullopt;
  return s.text(0);
}

void ResultsDb::set_meta(const std::string& key, const std::string& value) {
  Statement(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES(?, ?)", file_).bind(1, key).bind(2, value).run();
}

ResultsDb::~ResultsDb() { sqlite3_close(db_); }

void ResultsDb::execute(const std::string& sql) const {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string why = message ? message : "unknown error";
    sqlite3_free(message);
    throw std::runtime_error("results database " + file_ + ": " + why);
  }
}

std::optional<std::string> ResultsDb::status(const std::string& hash) const {
  Statement s(db_, "SELECT status FROM runs WHERE hash = ?", file_);
  s.bind(1, hash);
  if (!s.step()) return std::nullopt;
  return s.text(0);
}

void ResultsDb::mark_running(const StudyRun& run, const std::string& command, int order, int rank) {
  execute("BEGIN IMMEDIATE");
  try {
    Statement(db_,
              "INSERT OR REPLACE INTO runs(hash, command, dataset, run_order, status, started, rank, config_yaml) "
              "VALUES(?, ?, ?, ?, 'running', ?, ?, ?)",
              file_)
        .bind(1, run.hash).bind(2, command).bind(3, run.dataset).bind(4, order).bind(5, utc_now()).bind(6, rank)
        .bind(7, options_to_yaml(run.config)).run();
    Statement(db_, "DELETE FROM swept WHERE hash = ?", file_).bind(1, run.hash).run();
    Statement insert(db_, "INSERT INTO swept(hash, key, value) VALUES(?, ?, ?)", file_);
    for (const auto& [key, value] : run.values) insert.bind(1, run.hash).bind(2, key).bind(3, value).run();
    execute("COMMIT");
  } catch (...) {
    execute("ROLLBACK");
    throw;
  }
}

void ResultsDb::record(const std::string& hash, const RunOutcome& outcome) {
  execute("BEGIN IMMEDIATE");
  try {
    Statement(db_,
              "UPDATE runs SET status = ?, exit_code = ?, error = ?, wall_s = ?, finished = ?, out_dir = ? "
              "WHERE hash = ?",
              file_)
        .bind(1, outcome.status).bind(2, outcome.exit_code).bind(3, outcome.error).bind(4, outcome.wall_s)
        .bind(5, utc_now()).bind(6, outcome.out_dir).bind(7, hash).run();
    write_metrics(hash, outcome.metrics);
    execute("COMMIT");
  } catch (...) {
    execute("ROLLBACK");
    throw;
  }
}

void ResultsDb::write_metrics(const std::string& hash, const std::vector<std::pair<std::string, double>>& metrics) {
  Statement(db_, "DELETE FROM metrics WHERE hash = ?", file_).bind(1, hash).run();
  Statement insert(db_, "INSERT OR REPLACE INTO metrics(hash, name, value) VALUES(?, ?, ?)", file_);
  for (const auto& [name, value] : metrics) insert.bind(1, hash).bind(2, name).bind(3, value).run();
}

void ResultsDb::replace_metrics(const std::string& hash, const std::vector<std::pair<std::string, double>>& metrics) {
  execute("BEGIN IMMEDIATE");
  try {
    write_metrics(hash, metrics);
    execute("COMMIT");
  } catch (...) {
    execute("ROLLBACK");
    throw;
  }
}

std::vector<std::vector<std::string>> ResultsDb::query(const std::string& sql) const {
  Statement s(db_, sql, file_);
  std::vector<std::vector<std::string>> rows;
  while (s.step()) {
    rows.emplace_back();
    for (int c = 0; c < s.columns(); ++c) rows.back().push_back(s.text(c));
  }
  return rows;
}

}  // namespace twill
