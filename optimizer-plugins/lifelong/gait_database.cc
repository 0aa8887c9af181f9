#include "optimizer-plugins/lifelong/gait_database.h"

#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "common/format.h"
#include "common/status.h"

namespace yamor::lifelong {
namespace {

// 'YAMR': marks a yamor gait database (PRAGMA application_id).
constexpr int kApplicationId = 0x59414D52;

constexpr const char* kSchema = R"sql(
CREATE TABLE gaits (
  id INTEGER PRIMARY KEY,
  morphology_key TEXT NOT NULL,
  orientation TEXT NOT NULL CHECK (orientation IN ('upright', 'upside_down')),
  config_xml TEXT NOT NULL,
  problem_xml TEXT NOT NULL DEFAULT '',
  expected_velocity REAL NOT NULL,
  created REAL NOT NULL,
  last_used REAL NOT NULL,
  use_count INTEGER NOT NULL DEFAULT 0,
  predecessor INTEGER REFERENCES gaits(id),
  origin TEXT NOT NULL DEFAULT '',
  trigger TEXT NOT NULL DEFAULT '',
  velocity_before REAL NOT NULL DEFAULT 0,
  velocity_after REAL NOT NULL DEFAULT 0,
  has_acceleration INTEGER NOT NULL DEFAULT 0,
  acceleration_x REAL NOT NULL DEFAULT 0,
  acceleration_y REAL NOT NULL DEFAULT 0,
  acceleration_z REAL NOT NULL DEFAULT 0,
  acceleration_spread REAL NOT NULL DEFAULT 0,
  velocity_noise REAL NOT NULL DEFAULT 0,
  noise_windows INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX gaits_by_body ON gaits (morphology_key, orientation);
CREATE TABLE gait_parameters (
  gait_id INTEGER NOT NULL REFERENCES gaits(id),
  position INTEGER NOT NULL,
  name TEXT NOT NULL,
  value REAL NOT NULL,
  PRIMARY KEY (gait_id, position)
);
CREATE TABLE gait_defects (
  gait_id INTEGER NOT NULL REFERENCES gaits(id),
  defect TEXT NOT NULL,
  PRIMARY KEY (gait_id, defect)
);
CREATE TABLE uses (
  id INTEGER PRIMARY KEY,
  gait_id INTEGER NOT NULL REFERENCES gaits(id),
  time REAL NOT NULL,
  velocity REAL NOT NULL,
  previous INTEGER,
  outcome TEXT NOT NULL CHECK (outcome IN ('accepted', 'rejected'))
);
CREATE INDEX uses_by_switch ON uses (previous, gait_id, outcome);
)sql";

// Version 1 -> 2: each gait's window noise (unknown, 0, for the gaits stored before).
constexpr const char* kMigrateV1ToV2 = R"sql(
ALTER TABLE gaits ADD COLUMN velocity_noise REAL NOT NULL DEFAULT 0;
ALTER TABLE gaits ADD COLUMN noise_windows INTEGER NOT NULL DEFAULT 0;
PRAGMA user_version=2;
)sql";

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A prepared statement, finalized on scope exit.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& path, const char* sql) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) Fail("prepare");
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int i, double v) { return Check(sqlite3_bind_double(stmt_, i, v)); }
  Statement& Bind(int i, std::int64_t v) { return Check(sqlite3_bind_int64(stmt_, i, v)); }
  Statement& Bind(int i, int v) { return Check(sqlite3_bind_int(stmt_, i, v)); }
  Statement& Bind(int i, const std::string& v) {
    return Check(sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  Statement& BindNull(int i) { return Check(sqlite3_bind_null(stmt_, i)); }

  /// True while rows come; false when done.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    Fail("step");
  }
  void Run() {
    while (Step()) {
    }
    sqlite3_reset(stmt_);
  }

  double Double(int c) const { return sqlite3_column_double(stmt_, c); }
  std::int64_t Int(int c) const { return sqlite3_column_int64(stmt_, c); }
  bool IsNull(int c) const { return sqlite3_column_type(stmt_, c) == SQLITE_NULL; }
  std::string Text(int c) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, c));
    return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, c))) : std::string();
  }

 private:
  Statement& Check(int rc) {
    if (rc != SQLITE_OK) Fail("bind");
    return *this;
  }
  [[noreturn]] void Fail(const char* what) const;

  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

// The canonical code of a SQLite failure: damage is data loss, a busy or
// unreadable file is unavailable, the rest internal.
StatusCode CodeOf(int rc) {
  switch (rc & 0xff) {
    case SQLITE_NOTADB:
    case SQLITE_CORRUPT:
    case SQLITE_FORMAT: return StatusCode::kDataLoss;
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_FULL:
    case SQLITE_READONLY: return StatusCode::kUnavailable;
    case SQLITE_CONSTRAINT: return StatusCode::kInvalidArgument;
    default: return StatusCode::kInternal;
  }
}

[[noreturn]] void ThrowSqlite(sqlite3* db, const std::string& path, const std::string& what) {
  const int rc = db ? sqlite3_extended_errcode(db) : SQLITE_CANTOPEN;
  const std::string message = db ? sqlite3_errmsg(db) : "out of memory";
  std::string hint;
  if (CodeOf(rc) == StatusCode::kDataLoss) hint = " (not a gait database, or damaged)";
  throw Error(CodeOf(rc), "gait database " + path + ": " + what + ": " + message + hint);
}

void Statement::Fail(const char* what) const { ThrowSqlite(db_, path_, what); }

void Exec(sqlite3* db, const std::string& path, const char* sql) {
  char* error = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &error) != SQLITE_OK) {
    sqlite3_free(error);
    ThrowSqlite(db, path, std::string("executing ") + std::string(sql).substr(0, 40));
  }
}

// One write transaction: BEGIN IMMEDIATE, COMMIT on Commit(), ROLLBACK otherwise.
class Transaction {
 public:
  Transaction(sqlite3* db, const std::string& path) : db_(db), path_(path) {
    Exec(db_, path_, "BEGIN IMMEDIATE");
  }
  ~Transaction() {
    if (!done_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  void Commit() {
    Exec(db_, path_, "COMMIT");
    done_ = true;
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  bool done_ = false;
};

void CheckFinite(double v, const std::string& what) {
  if (!std::isfinite(v)) {
    throw Error(StatusCode::kInvalidArgument, "gait " + what + " is not finite: " + FormatRounded(v));
  }
}

int IntPragma(sqlite3* db, const std::string& path, const char* sql) {
  Statement s(db, path, sql);
  return s.Step() ? static_cast<int>(s.Int(0)) : 0;
}

}  // namespace

const char* OrientationName(Orientation orientation) {
  return orientation == Orientation::kUpright ? "upright" : "upside_down";
}

Orientation ParseOrientation(std::string_view name) {
  if (name == "upright") return Orientation::kUpright;
  if (name == "upside_down") return Orientation::kUpsideDown;
  throw Error(StatusCode::kInvalidArgument,
              "unknown orientation \"" + std::string(name) + "\" (upright or upside_down)");
}

double Symptoms::Drop() const {
  if (velocity_before == 0) return 0;
  return (velocity_before - velocity_after) / std::fabs(velocity_before);
}

double Likelihood(const GaitRecord& candidate, const GaitQuery& query, std::int64_t switches,
                  std::string* reasons) {
  std::ostringstream why;
  double score = 0;
  auto sorted = [](std::vector<std::string> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  if (sorted(candidate.symptoms.defects) == sorted(query.symptoms.defects)) {
    score += 3.0;
    why << "same defects";
  }
  const double drop =
      2.0 * std::exp(-std::fabs(candidate.symptoms.Drop() - query.symptoms.Drop()) / 0.25);
  score += drop;
  why << (why.tellp() > 0 ? ", " : "") << "drop alike " << FormatRounded(drop / 2.0);
  if (candidate.symptoms.has_acceleration && query.symptoms.has_acceleration) {
    double d2 = 0;
    for (int i = 0; i < 3; ++i) {
      const double d = candidate.symptoms.acceleration[i] - query.symptoms.acceleration[i];
      d2 += d * d;
    }
    const double a = std::exp(-std::sqrt(d2) / 2.0);
    score += a;
    why << ", acceleration alike " << FormatRounded(a);
  }
  std::int64_t links = switches;
  if (query.current && candidate.predecessor == query.current) ++links;  // learned when it failed before
  if (links > 0) {
    score += 1.5;
    why << ", followed the current gait before (" << links << ")";
  }
  const double use = 0.5 * std::min(1.0, std::log1p(static_cast<double>(candidate.use_count)) / std::log(101.0));
  score += use;
  if (candidate.use_count > 0) why << ", used " << candidate.use_count << "x";
  if (reasons) *reasons = why.str();
  return score;
}

GaitDatabase::GaitDatabase(const std::string& path, bool create) : path_(path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool exists = fs::exists(path, ec);
  if (!exists && !create) throw Error(StatusCode::kNotFound, "gait database " + path + " does not exist");
  if (exists && fs::is_directory(path, ec)) {
    throw Error(StatusCode::kFailedPrecondition, "gait database " + path + " is a folder");
  }
  if (!exists) {
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
      throw Error(StatusCode::kNotFound, "gait database " + path + ": folder " + parent.string() + " does not exist");
    }
  }
  const int rc = sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(StatusCode::kUnavailable, "gait database " + path + ": cannot open: " + message);
  }
  try {
    sqlite3_busy_timeout(db_, 10000);
    sqlite3_extended_result_codes(db_, 1);
    // The first read of the file: a non-database fails here with NOTADB.
    {
      Statement mode(db_, path_, "PRAGMA journal_mode=WAL");
      if (!mode.Step() || mode.Text(0) != "wal") {
        throw Error(StatusCode::kUnavailable, "gait database " + path + ": cannot use WAL journal mode");
      }
    }
    Exec(db_, path_, "PRAGMA synchronous=FULL");
    Exec(db_, path_, "PRAGMA foreign_keys=ON");
    {
      Statement check(db_, path_, "PRAGMA quick_check");
      std::string first;
      if (check.Step()) first = check.Text(0);
      if (first != "ok") {
        throw Error(StatusCode::kDataLoss, "gait database " + path + " is damaged: " + first);
      }
    }
    const int application = IntPragma(db_, path_, "PRAGMA application_id");
    const int version = IntPragma(db_, path_, "PRAGMA user_version");
    const int tables = IntPragma(db_, path_, "SELECT count(*) FROM sqlite_master");
    if (application == 0 && version == 0 && tables == 0) {
      Transaction t(db_, path_);
      Exec(db_, path_, kSchema);
      Exec(db_, path_, ("PRAGMA application_id=" + std::to_string(kApplicationId)).c_str());
      Exec(db_, path_, ("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str());
      t.Commit();
    } else if (application != kApplicationId) {
      throw Error(StatusCode::kDataLoss,
                  "gait database " + path + " is a SQLite database of another application, not a yamor gait database");
    } else if (version > kSchemaVersion) {
      throw Error(StatusCode::kFailedPrecondition,
                  "gait database " + path + " has schema version " + std::to_string(version) +
                      ", newer than this build's " + std::to_string(kSchemaVersion) +
                      "; use a newer yamor-lifelong or another --db");
    } else if (version < 1) {
      throw Error(StatusCode::kDataLoss, "gait database " + path + " has no schema version");
    } else if (version < kSchemaVersion) {
      Migrate();
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

GaitDatabase::~GaitDatabase() { sqlite3_close(db_); }

void GaitDatabase::Migrate() {
  // One transaction for every step: a kill in the middle leaves the old
  // version whole (the next open migrates again). The version is read again
  // under the write lock: another process may have migrated the file since.
  Transaction t(db_, path_);
  int version = IntPragma(db_, path_, "PRAGMA user_version");
  try {
    if (version == 1) {
      Exec(db_, path_, kMigrateV1ToV2);
      version = 2;
    }
  } catch (const Error& e) {
    // A file that says it is version 1 but has not its tables is damaged.
    if (e.code() != StatusCode::kInternal) throw;
    throw Error(StatusCode::kDataLoss, "gait database " + path_ + " cannot be migrated from schema version " +
                                           std::to_string(version) + " (damaged?): " + e.what());
  }
  if (version != kSchemaVersion) {
    throw Error(StatusCode::kDataLoss, "gait database " + path_ + " has schema version " +
                                           std::to_string(version) + ", which this build cannot migrate");
  }
  t.Commit();
}

std::int64_t GaitDatabase::Insert(const GaitRecord& record) {
  if (record.morphology_key.empty()) throw Error(StatusCode::kInvalidArgument, "gait without a morphology key");
  if (record.config_xml.empty()) throw Error(StatusCode::kInvalidArgument, "gait without a configuration");
  CheckFinite(record.expected_velocity, "expected velocity");
  CheckFinite(record.created, "creation time");
  CheckFinite(record.last_used, "last use time");
  CheckFinite(record.symptoms.velocity_before, "velocity before the anomaly");
  CheckFinite(record.symptoms.velocity_after, "velocity after the anomaly");
  CheckFinite(record.symptoms.acceleration_spread, "acceleration spread");
  for (double a : record.symptoms.acceleration) CheckFinite(a, "acceleration");
  for (const auto& [name, value] : record.parameters) CheckFinite(value, "parameter " + name);
  CheckFinite(record.velocity_noise, "velocity noise");
  if (record.velocity_noise < 0 || record.noise_windows < 0) {
    throw Error(StatusCode::kInvalidArgument, "gait velocity noise and its window count must be >= 0");
  }
  const double now = Now();
  std::lock_guard lock(mu_);
  Transaction t(db_, path_);
  if (record.predecessor) {
    Statement s(db_, path_, "SELECT 1 FROM gaits WHERE id = ?");
    s.Bind(1, *record.predecessor);
    if (!s.Step()) {
      throw Error(StatusCode::kNotFound, "gait database " + path_ + ": predecessor gait " +
                                            std::to_string(*record.predecessor) + " is not stored");
    }
  }
  Statement s(db_, path_,
              "INSERT INTO gaits (morphology_key, orientation, config_xml, problem_xml, expected_velocity, "
              "created, last_used, use_count, predecessor, origin, trigger, velocity_before, velocity_after, "
              "has_acceleration, acceleration_x, acceleration_y, acceleration_z, acceleration_spread, "
              "velocity_noise, noise_windows) "
              "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s.Bind(1, record.morphology_key)
      .Bind(2, std::string(OrientationName(record.orientation)))
      .Bind(3, record.config_xml)
      .Bind(4, record.problem_xml)
      .Bind(5, record.expected_velocity)
      .Bind(6, record.created != 0 ? record.created : now)
      .Bind(7, record.last_used != 0 ? record.last_used : now)
      .Bind(8, record.use_count);
  if (record.predecessor) {
    s.Bind(9, *record.predecessor);
  } else {
    s.BindNull(9);
  }
  s.Bind(10, record.origin)
      .Bind(11, record.symptoms.trigger)
      .Bind(12, record.symptoms.velocity_before)
      .Bind(13, record.symptoms.velocity_after)
      .Bind(14, record.symptoms.has_acceleration ? 1 : 0)
      .Bind(15, record.symptoms.acceleration[0])
      .Bind(16, record.symptoms.acceleration[1])
      .Bind(17, record.symptoms.acceleration[2])
      .Bind(18, record.symptoms.acceleration_spread)
      .Bind(19, record.velocity_noise)
      .Bind(20, record.noise_windows);
  s.Run();
  const std::int64_t id = sqlite3_last_insert_rowid(db_);
  {
    Statement p(db_, path_, "INSERT INTO gait_parameters (gait_id, position, name, value) VALUES (?,?,?,?)");
    int position = 0;
    for (const auto& [name, value] : record.parameters) {
      p.Bind(1, id).Bind(2, position++).Bind(3, name).Bind(4, value);
      p.Run();
    }
  }
  {
    Statement d(db_, path_, "INSERT OR IGNORE INTO gait_defects (gait_id, defect) VALUES (?,?)");
    for (const std::string& defect : record.symptoms.defects) {
      d.Bind(1, id).Bind(2, defect);
      d.Run();
    }
  }
  t.Commit();
  return id;
}

void GaitDatabase::RecordUse(std::int64_t id, double unix_time, double velocity,
                             std::optional<std::int64_t> previous, UseOutcome outcome) {
  CheckFinite(unix_time, "use time");
  CheckFinite(velocity, "velocity");
  std::lock_guard lock(mu_);
  Transaction t(db_, path_);
  {
    Statement s(db_, path_, "SELECT 1 FROM gaits WHERE id = ?");
    s.Bind(1, id);
    if (!s.Step()) {
      throw Error(StatusCode::kNotFound, "gait database " + path_ + ": gait " + std::to_string(id) + " is not stored");
    }
  }
  {
    Statement s(db_, path_, "INSERT INTO uses (gait_id, time, velocity, previous, outcome) VALUES (?,?,?,?,?)");
    s.Bind(1, id).Bind(2, unix_time).Bind(3, velocity);
    if (previous) {
      s.Bind(4, *previous);
    } else {
      s.BindNull(4);
    }
    s.Bind(5, std::string(outcome == UseOutcome::kAccepted ? "accepted" : "rejected"));
    s.Run();
  }
  if (outcome == UseOutcome::kAccepted) {
    Statement s(db_, path_,
                "UPDATE gaits SET use_count = use_count + 1, last_used = ?, expected_velocity = ? WHERE id = ?");
    s.Bind(1, unix_time).Bind(2, velocity).Bind(3, id);
    s.Run();
  }
  t.Commit();
}

void GaitDatabase::SetExpectedVelocity(std::int64_t id, double velocity) {
  CheckFinite(velocity, "expected velocity");
  std::lock_guard lock(mu_);
  Transaction t(db_, path_);
  Statement s(db_, path_, "UPDATE gaits SET expected_velocity = ? WHERE id = ?");
  s.Bind(1, velocity).Bind(2, id);
  s.Run();
  if (sqlite3_changes(db_) != 1) {
    throw Error(StatusCode::kNotFound, "gait database " + path_ + ": gait " + std::to_string(id) + " is not stored");
  }
  t.Commit();
}

void GaitDatabase::SetNoise(std::int64_t id, double noise, std::int64_t windows,
                            std::optional<double> expected_velocity) {
  CheckFinite(noise, "velocity noise");
  if (expected_velocity) CheckFinite(*expected_velocity, "expected velocity");
  if (noise < 0 || windows < 0) {
    throw Error(StatusCode::kInvalidArgument, "gait velocity noise " + FormatRounded(noise) + " and its window count " +
                                                  std::to_string(windows) + " must be >= 0");
  }
  std::lock_guard lock(mu_);
  Transaction t(db_, path_);
  Statement s(db_, path_,
              "UPDATE gaits SET velocity_noise = ?, noise_windows = ?, "
              "expected_velocity = coalesce(?, expected_velocity) WHERE id = ?");
  s.Bind(1, noise).Bind(2, windows);
  if (expected_velocity) {
    s.Bind(3, *expected_velocity);
  } else {
    s.BindNull(3);
  }
  s.Bind(4, id);
  s.Run();
  if (sqlite3_changes(db_) != 1) {
    throw Error(StatusCode::kNotFound, "gait database " + path_ + ": gait " + std::to_string(id) + " is not stored");
  }
  t.Commit();
}

GaitRecord GaitDatabase::ReadLocked(std::int64_t id) const {
  GaitRecord r;
  {
    Statement s(db_, path_,
                "SELECT id, morphology_key, orientation, config_xml, problem_xml, expected_velocity, created, "
                "last_used, use_count, predecessor, origin, trigger, velocity_before, velocity_after, "
                "has_acceleration, acceleration_x, acceleration_y, acceleration_z, acceleration_spread, "
                "velocity_noise, noise_windows FROM gaits WHERE id = ?");
    s.Bind(1, id);
    if (!s.Step()) {
      throw Error(StatusCode::kNotFound, "gait database " + path_ + ": gait " + std::to_string(id) + " is not stored");
    }
    r.id = s.Int(0);
    r.morphology_key = s.Text(1);
    try {
      r.orientation = ParseOrientation(s.Text(2));
    } catch (const Error&) {
      throw Error(StatusCode::kDataLoss, "gait database " + path_ + ": gait " + std::to_string(id) +
                                             " has orientation \"" + s.Text(2) + "\"");
    }
    r.config_xml = s.Text(3);
    r.problem_xml = s.Text(4);
    r.expected_velocity = s.Double(5);
    r.created = s.Double(6);
    r.last_used = s.Double(7);
    r.use_count = s.Int(8);
    if (!s.IsNull(9)) r.predecessor = s.Int(9);
    r.origin = s.Text(10);
    r.symptoms.trigger = s.Text(11);
    r.symptoms.velocity_before = s.Double(12);
    r.symptoms.velocity_after = s.Double(13);
    r.symptoms.has_acceleration = s.Int(14) != 0;
    for (int i = 0; i < 3; ++i) r.symptoms.acceleration[i] = s.Double(15 + i);
    r.symptoms.acceleration_spread = s.Double(18);
    r.velocity_noise = s.Double(19);
    r.noise_windows = s.Int(20);
  }
  {
    Statement s(db_, path_, "SELECT name, value FROM gait_parameters WHERE gait_id = ? ORDER BY position");
    s.Bind(1, id);
    while (s.Step()) r.parameters.emplace_back(s.Text(0), s.Double(1));
  }
  {
    Statement s(db_, path_, "SELECT defect FROM gait_defects WHERE gait_id = ? ORDER BY defect");
    s.Bind(1, id);
    while (s.Step()) r.symptoms.defects.push_back(s.Text(0));
  }
  return r;
}

std::vector<std::int64_t> GaitDatabase::IdsLocked(const std::string& sql,
                                                  const std::vector<std::string>& args) const {
  Statement s(db_, path_, sql.c_str());
  for (std::size_t i = 0; i < args.size(); ++i) s.Bind(static_cast<int>(i + 1), args[i]);
  std::vector<std::int64_t> ids;
  while (s.Step()) ids.push_back(s.Int(0));
  return ids;
}

std::optional<GaitRecord> GaitDatabase::Find(std::int64_t id) const {
  std::lock_guard lock(mu_);
  Statement s(db_, path_, "SELECT 1 FROM gaits WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadLocked(id);
}

std::optional<GaitRecord> GaitDatabase::FindSame(const std::string& morphology_key, Orientation orientation,
                                                 const std::string& config_xml) const {
  std::lock_guard lock(mu_);
  const auto ids = IdsLocked(
      "SELECT id FROM gaits WHERE morphology_key = ? AND orientation = ? AND config_xml = ? ORDER BY id LIMIT 1",
      {morphology_key, OrientationName(orientation), config_xml});
  if (ids.empty()) return std::nullopt;
  return ReadLocked(ids.front());
}

std::vector<GaitRecord> GaitDatabase::All() const {
  std::lock_guard lock(mu_);
  std::vector<GaitRecord> out;
  for (std::int64_t id : IdsLocked("SELECT id FROM gaits ORDER BY id", {})) out.push_back(ReadLocked(id));
  return out;
}

std::int64_t GaitDatabase::Switches(std::int64_t from, std::int64_t to) const {
  std::lock_guard lock(mu_);
  Statement s(db_, path_,
              "SELECT count(*) FROM uses WHERE previous = ? AND gait_id = ? AND outcome = 'accepted'");
  s.Bind(1, from).Bind(2, to);
  return s.Step() ? s.Int(0) : 0;
}

std::vector<RankedGait> GaitDatabase::Match(const GaitQuery& query) const {
  std::vector<GaitRecord> candidates;
  std::optional<std::int64_t> current_predecessor;
  {
    std::lock_guard lock(mu_);
    for (std::int64_t id : IdsLocked("SELECT id FROM gaits WHERE morphology_key = ? AND orientation = ? ORDER BY id",
                                     {query.morphology_key, OrientationName(query.orientation)})) {
      if (query.current && id == *query.current) continue;
      candidates.push_back(ReadLocked(id));
    }
    if (query.current) {
      Statement s(db_, path_, "SELECT predecessor FROM gaits WHERE id = ?");
      s.Bind(1, *query.current);
      if (s.Step() && !s.IsNull(0)) current_predecessor = s.Int(0);
    }
  }
  std::vector<RankedGait> ranked;
  for (GaitRecord& g : candidates) {
    std::int64_t switches = query.current ? Switches(*query.current, g.id) : 0;
    // The current gait replaced this one: the old situation may be back.
    if (current_predecessor && *current_predecessor == g.id) ++switches;
    RankedGait r;
    r.likelihood = Likelihood(g, query, switches, &r.reasons);
    r.gait = std::move(g);
    ranked.push_back(std::move(r));
  }
  std::sort(ranked.begin(), ranked.end(), [](const RankedGait& a, const RankedGait& b) {
    if (a.likelihood != b.likelihood) return a.likelihood > b.likelihood;
    if (a.gait.last_used != b.gait.last_used) return a.gait.last_used > b.gait.last_used;
    return a.gait.id < b.gait.id;
  });
  if (query.limit >= 0 && static_cast<int>(ranked.size()) > query.limit) ranked.resize(query.limit);
  return ranked;
}

}  // namespace yamor::lifelong
