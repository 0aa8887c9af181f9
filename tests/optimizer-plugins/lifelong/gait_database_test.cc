#include "optimizer-plugins/lifelong/gait_database.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;

class GaitDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("gait_db_test_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name = "gaits.sqlite") const { return (dir_ / name).string(); }

  fs::path dir_;
};

GaitRecord Gait(const std::string& key, double velocity, const std::string& xml = "<yamorconfig/>") {
  GaitRecord g;
  g.morphology_key = key;
  g.config_xml = xml;
  g.problem_xml = "<yamorconfig><optimize param=\"amplitude.0\" min=\"0\" max=\"1\"/></yamorconfig>";
  g.parameters = {{"phase.0.1", 1.5}, {"amplitude.0", 0.25}, {"offset.5", -0.5}};
  g.expected_velocity = velocity;
  g.created = 1000;
  g.last_used = 1000;
  g.origin = "test";
  return g;
}

StatusCode CodeOf(const std::function<void()>& f, std::string* message = nullptr) {
  try {
    f();
  } catch (const Error& e) {
    if (message) *message = e.what();
    return e.code();
  }
  return StatusCode::kOk;
}

void RawExec(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);
}

TEST_F(GaitDatabaseTest, ARecordRoundTripsWithEveryField) {
  GaitRecord g = Gait("abcd", 0.05);
  g.orientation = Orientation::kUpsideDown;
  g.use_count = 3;
  g.symptoms = {.trigger = "velocity_drop",
                .velocity_before = 0.05,
                .velocity_after = 0.01,
                .has_acceleration = true,
                .acceleration = {0.1, -0.2, -9.7},
                .acceleration_spread = 1.25,
                .defects = {"module 5", "motor 3 limp"}};
  g.velocity_noise = 0.0125;
  g.noise_windows = 37;
  std::int64_t id = 0;
  {
    GaitDatabase db(Path());
    const std::int64_t first = db.Insert(Gait("abcd", 0.04));
    g.predecessor = first;
    id = db.Insert(g);
    EXPECT_NE(id, first);
  }
  GaitDatabase db(Path(), /*create=*/false);  // survives closing
  const auto found = db.Find(id);
  ASSERT_TRUE(found);
  g.id = id;
  EXPECT_EQ(*found, g);
  EXPECT_FALSE(db.Find(id + 100));
  EXPECT_EQ(db.All().size(), 2u);
}

TEST_F(GaitDatabaseTest, TheFileIsInWalModeWithTheSchemaVersion) {
  { GaitDatabase db(Path()); }
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(Path().c_str(), &raw), SQLITE_OK);
  auto pragma = [&](const char* sql) {
    sqlite3_stmt* s = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(raw, sql, -1, &s, nullptr), SQLITE_OK);
    EXPECT_EQ(sqlite3_step(s), SQLITE_ROW);
    std::string v = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
    sqlite3_finalize(s);
    return v;
  };
  EXPECT_EQ(pragma("PRAGMA journal_mode"), "wal");
  EXPECT_EQ(pragma("PRAGMA user_version"), std::to_string(GaitDatabase::kSchemaVersion));
  sqlite3_close(raw);
}

TEST_F(GaitDatabaseTest, FindSameFindsAnIdenticalGaitOnly) {
  GaitDatabase db(Path());
  const std::int64_t id = db.Insert(Gait("k1", 0.05, "<a/>"));
  ASSERT_TRUE(db.FindSame("k1", Orientation::kUpright, "<a/>"));
  EXPECT_EQ(db.FindSame("k1", Orientation::kUpright, "<a/>")->id, id);
  EXPECT_FALSE(db.FindSame("k1", Orientation::kUpright, "<b/>"));
  EXPECT_FALSE(db.FindSame("k2", Orientation::kUpright, "<a/>"));
  EXPECT_FALSE(db.FindSame("k1", Orientation::kUpsideDown, "<a/>"));
}

TEST_F(GaitDatabaseTest, AnAcceptedUseCountsAndUpdatesTheExpectation) {
  GaitDatabase db(Path());
  const std::int64_t a = db.Insert(Gait("k", 0.05));
  const std::int64_t b = db.Insert(Gait("k", 0.03));
  db.RecordUse(b, 2000, 0.02, a, UseOutcome::kRejected);
  EXPECT_EQ(db.Find(b)->use_count, 0);
  EXPECT_DOUBLE_EQ(db.Find(b)->expected_velocity, 0.03);
  db.RecordUse(b, 3000, 0.035, a, UseOutcome::kAccepted);
  const GaitRecord r = *db.Find(b);
  EXPECT_EQ(r.use_count, 1);
  EXPECT_DOUBLE_EQ(r.last_used, 3000);
  EXPECT_DOUBLE_EQ(r.expected_velocity, 0.035);
  EXPECT_EQ(db.Switches(a, b), 1);
  EXPECT_EQ(db.Switches(b, a), 0);
  EXPECT_EQ(CodeOf([&] { db.RecordUse(99, 1, 1, std::nullopt, UseOutcome::kAccepted); }),
            StatusCode::kNotFound);
}

TEST_F(GaitDatabaseTest, MatchKeepsTheBodyAndOrientationAndLeavesTheCurrentGaitOut) {
  GaitDatabase db(Path());
  const std::int64_t a = db.Insert(Gait("body", 0.05, "<a/>"));
  const std::int64_t b = db.Insert(Gait("body", 0.04, "<b/>"));
  db.Insert(Gait("other-body", 0.06, "<c/>"));
  GaitRecord flipped = Gait("body", 0.03, "<d/>");
  flipped.orientation = Orientation::kUpsideDown;
  const std::int64_t d = db.Insert(flipped);
  GaitQuery q{.morphology_key = "body", .current = a};
  auto m = db.Match(q);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].gait.id, b);
  q.orientation = Orientation::kUpsideDown;
  m = db.Match(q);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].gait.id, d);
  q.limit = 0;
  EXPECT_TRUE(db.Match(q).empty());
}

TEST_F(GaitDatabaseTest, TheSlipperyGroundStoryIsRankedByLikelihood) {
  // A: the initial gait. B: learned when A failed on slippery ground (a 60 %
  // drop). C: learned for a limp motor.
  GaitDatabase db(Path());
  const std::int64_t a = db.Insert(Gait("q", 0.05, "<a/>"));
  GaitRecord b = Gait("q", 0.03, "<b/>");
  b.predecessor = a;
  b.symptoms = {.trigger = "velocity_drop", .velocity_before = 0.05, .velocity_after = 0.02};
  const std::int64_t b_id = db.Insert(b);
  GaitRecord c = Gait("q", 0.035, "<c/>");
  c.predecessor = a;
  c.symptoms = {.trigger = "defect_set", .velocity_before = 0.05, .velocity_after = 0.04,
                .defects = {"motor 3 limp"}};
  const std::int64_t c_id = db.Insert(c);
  // Back on normal ground B runs too slowly: A, the gait B replaced, first.
  auto m = db.Match({.morphology_key = "q",
                     .symptoms = {.trigger = "velocity_drop", .velocity_before = 0.03, .velocity_after = 0.02},
                     .current = b_id});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gait.id, a) << m[0].reasons;
  EXPECT_GT(m[0].likelihood, m[1].likelihood);
  // Slippery again while walking A: B (same drop, no defect) before C.
  m = db.Match({.morphology_key = "q",
                .symptoms = {.trigger = "velocity_drop", .velocity_before = 0.05, .velocity_after = 0.022},
                .current = a});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gait.id, b_id) << m[0].reasons;
  EXPECT_EQ(m[1].gait.id, c_id);
  // The motor goes limp again while walking A: C first.
  m = db.Match({.morphology_key = "q",
                .symptoms = {.trigger = "defect_set", .velocity_before = 0.05, .velocity_after = 0.045,
                             .defects = {"motor 3 limp"}},
                .current = a});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gait.id, c_id) << m[0].reasons;
}

TEST_F(GaitDatabaseTest, SwitchesMadeBeforeRaiseTheLikelihood) {
  GaitDatabase db(Path());
  const std::int64_t a = db.Insert(Gait("q", 0.05, "<a/>"));
  const std::int64_t b = db.Insert(Gait("q", 0.03, "<b/>"));
  const std::int64_t c = db.Insert(Gait("q", 0.03, "<c/>"));
  auto m = db.Match({.morphology_key = "q", .current = a});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gait.id, b);  // equal scores: the lower id
  db.RecordUse(c, 5000, 0.03, a, UseOutcome::kAccepted);
  m = db.Match({.morphology_key = "q", .current = a});
  EXPECT_EQ(m[0].gait.id, c) << m[0].reasons;
}

TEST_F(GaitDatabaseTest, BadRecordsAreRefused) {
  GaitDatabase db(Path());
  EXPECT_EQ(CodeOf([&] { db.Insert(Gait("", 0.05)); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { db.Insert(Gait("k", 0.05, "")); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { db.Insert(Gait("k", std::numeric_limits<double>::quiet_NaN())); }),
            StatusCode::kInvalidArgument);
  GaitRecord g = Gait("k", 0.05);
  g.parameters.emplace_back("phase.1.2", std::numeric_limits<double>::infinity());
  EXPECT_EQ(CodeOf([&] { db.Insert(g); }), StatusCode::kInvalidArgument);
  g = Gait("k", 0.05);
  g.predecessor = 42;
  EXPECT_EQ(CodeOf([&] { db.Insert(g); }), StatusCode::kNotFound);
  EXPECT_TRUE(db.All().empty());  // nothing half-written
}

TEST_F(GaitDatabaseTest, TheWindowNoiseIsStoredInOneWrite) {
  GaitDatabase db(Path());
  const std::int64_t a = db.Insert(Gait("k", 0.05));
  EXPECT_DOUBLE_EQ(db.Find(a)->velocity_noise, 0);  // unknown
  EXPECT_EQ(db.Find(a)->noise_windows, 0);
  db.SetNoise(a, 0.007, 12);
  {
    GaitDatabase other(Path(), /*create=*/false);  // committed: another connection sees it
    EXPECT_DOUBLE_EQ(other.Find(a)->velocity_noise, 0.007);
    EXPECT_EQ(other.Find(a)->noise_windows, 12);
  }
  db.SetNoise(a, 0.004, 30);
  EXPECT_DOUBLE_EQ(db.Find(a)->velocity_noise, 0.004);
  EXPECT_EQ(db.Find(a)->noise_windows, 30);
  EXPECT_DOUBLE_EQ(db.Find(a)->expected_velocity, 0.05);  // nothing else changes
  db.SetNoise(a, 0.005, 36, 0.045);  // with the EMA it is measured around
  EXPECT_DOUBLE_EQ(db.Find(a)->velocity_noise, 0.005);
  EXPECT_EQ(db.Find(a)->noise_windows, 36);
  EXPECT_DOUBLE_EQ(db.Find(a)->expected_velocity, 0.045);
  EXPECT_EQ(CodeOf([&] { db.SetNoise(a, 0.01, 3, std::numeric_limits<double>::infinity()); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { db.SetNoise(a + 5, 0.01, 3); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { db.SetNoise(a, -0.01, 3); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { db.SetNoise(a, std::numeric_limits<double>::quiet_NaN(), 3); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { db.SetNoise(a, 0.01, -1); }), StatusCode::kInvalidArgument);
  GaitRecord bad = Gait("k", 0.05);
  bad.velocity_noise = -1;
  EXPECT_EQ(CodeOf([&] { db.Insert(bad); }), StatusCode::kInvalidArgument);
}

// The version-1 schema as it was shipped, with one gait, written by raw SQL.
void WriteVersionOne(const std::string& path) {
  RawExec(path, R"sql(
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
  acceleration_spread REAL NOT NULL DEFAULT 0
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
INSERT INTO gaits (id, morphology_key, orientation, config_xml, expected_velocity, created, last_used, use_count,
                   origin, trigger, velocity_before, velocity_after)
  VALUES (4, 'old-key', 'upside_down', '<yamorconfig/>', 0.031, 100, 200, 3, 'online', 'velocity_drop', 0.08, 0.01);
INSERT INTO gait_parameters VALUES (4, 0, 'amplitude.0', 0.75);
INSERT INTO gait_defects VALUES (4, 'motor 2 limp');
INSERT INTO uses (gait_id, time, velocity, previous, outcome) VALUES (4, 200, 0.031, NULL, 'accepted');
PRAGMA application_id=1497451858;
PRAGMA user_version=1;
)sql");
}

std::string Pragma(const std::string& path, const char* sql) {
  sqlite3* raw = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &raw), SQLITE_OK);
  sqlite3_stmt* s = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(raw, sql, -1, &s, nullptr), SQLITE_OK);
  std::string v;
  if (sqlite3_step(s) == SQLITE_ROW) v = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
  sqlite3_finalize(s);
  sqlite3_close(raw);
  return v;
}

TEST_F(GaitDatabaseTest, AVersionOneFileIsMigratedInPlaceKeepingItsGaits) {
  WriteVersionOne(Path());
  ASSERT_EQ(Pragma(Path(), "PRAGMA user_version"), "1");
  {
    GaitDatabase db(Path(), /*create=*/false);
    const auto g = db.Find(4);
    ASSERT_TRUE(g);
    EXPECT_EQ(g->morphology_key, "old-key");
    EXPECT_EQ(g->orientation, Orientation::kUpsideDown);
    EXPECT_DOUBLE_EQ(g->expected_velocity, 0.031);
    EXPECT_EQ(g->use_count, 3);
    EXPECT_EQ(g->parameters, (std::vector<std::pair<std::string, double>>{{"amplitude.0", 0.75}}));
    EXPECT_EQ(g->symptoms.defects, std::vector<std::string>{"motor 2 limp"});
    EXPECT_DOUBLE_EQ(g->velocity_noise, 0);  // unknown until it walks again
    EXPECT_EQ(g->noise_windows, 0);
    db.SetNoise(4, 0.006, 9);
    const std::int64_t b = db.Insert(Gait("old-key", 0.02));
    EXPECT_GT(b, 4);
  }
  EXPECT_EQ(Pragma(Path(), "PRAGMA user_version"), std::to_string(GaitDatabase::kSchemaVersion));
  // Opening the migrated file again changes nothing.
  GaitDatabase db(Path(), /*create=*/false);
  EXPECT_DOUBLE_EQ(db.Find(4)->velocity_noise, 0.006);
  EXPECT_EQ(db.Find(4)->noise_windows, 9);
  EXPECT_EQ(db.All().size(), 2u);
}

TEST_F(GaitDatabaseTest, AVersionOneFileWithoutItsTablesIsDataLossNotACrash) {
  RawExec(Path(), "CREATE TABLE other (x INTEGER); PRAGMA application_id=1497451858; PRAGMA user_version=1;");
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path()); }, &message), StatusCode::kDataLoss);
  EXPECT_NE(message.find(Path()), std::string::npos) << message;
  EXPECT_NE(message.find("migrated"), std::string::npos) << message;
  // The failed migration changed nothing (one transaction).
  EXPECT_EQ(Pragma(Path(), "PRAGMA user_version"), "1");
}

TEST_F(GaitDatabaseTest, AMissingFileOrFolderIsNotFound) {
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path(), /*create=*/false); }, &message), StatusCode::kNotFound);
  EXPECT_NE(message.find(Path()), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db((dir_ / "no" / "such" / "gaits.sqlite").string()); }, &message),
            StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(dir_.string()); }), StatusCode::kFailedPrecondition);
}

TEST_F(GaitDatabaseTest, AFileThatIsNotADatabaseIsAClearError) {
  {
    std::ofstream out(Path());
    out << "timeline,velocity\n0,0.05\n this is a text file, not SQLite ......................................"
           "................................................................................................\n";
  }
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path()); }, &message), StatusCode::kDataLoss);
  EXPECT_NE(message.find(Path()), std::string::npos) << message;
}

TEST_F(GaitDatabaseTest, ADamagedDatabaseIsAClearError) {
  {
    GaitDatabase db(Path());
    for (int i = 0; i < 200; ++i) db.Insert(Gait("key" + std::to_string(i), 0.05, std::string(500, 'x')));
  }
  // Fold the WAL into the main file, then overwrite a page in the middle.
  RawExec(Path(), "PRAGMA wal_checkpoint(TRUNCATE)");
  ASSERT_GT(fs::file_size(Path()), 40000u);
  {
    std::fstream f(Path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(4096 * 4);
    const std::string junk(8192, '\xA5');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path()); }, &message), StatusCode::kDataLoss);
  EXPECT_NE(message.find(Path()), std::string::npos) << message;
}

TEST_F(GaitDatabaseTest, ASqliteFileOfAnotherApplicationIsRefused) {
  RawExec(Path(), "CREATE TABLE customers (id INTEGER PRIMARY KEY, name TEXT)");
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path()); }, &message), StatusCode::kDataLoss);
  EXPECT_NE(message.find("not a yamor gait database"), std::string::npos) << message;
}

TEST_F(GaitDatabaseTest, ANewerSchemaVersionIsRefusedNamingBothVersions) {
  { GaitDatabase db(Path()); }
  RawExec(Path(), "PRAGMA user_version=7");
  std::string message;
  EXPECT_EQ(CodeOf([&] { GaitDatabase db(Path()); }, &message), StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("schema version 7"), std::string::npos) << message;
  EXPECT_NE(message.find(Path()), std::string::npos) << message;
}

// The record a writer stores as its i-th gait (so the reader can check it).
GaitRecord Numbered(int i) {
  GaitRecord g = Gait("kill-test", 0.001 * i, "<yamorconfig n=\"" + std::to_string(i) + "\"/>");
  g.parameters.clear();
  for (int p = 0; p < 20; ++p) g.parameters.emplace_back("phase." + std::to_string(p) + ".1", i + 0.01 * p);
  g.symptoms.defects = {"motor " + std::to_string(i % 9) + " limp"};
  return g;
}

TEST_F(GaitDatabaseTest, KillNineMidWriteLosesNothingCommitted) {
  for (int round = 0; round < 3; ++round) {
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      close(fds[0]);
      try {
        GaitDatabase db(Path());
        for (int i = 0;; ++i) {
          const std::int64_t id = db.Insert(Numbered(i));
          db.RecordUse(id, 100 + i, 0.001 * i, std::nullopt, UseOutcome::kAccepted);
          const std::int64_t message[2] = {id, i};
          if (write(fds[1], message, sizeof message) != sizeof message) _exit(3);
        }
      } catch (...) {
        _exit(2);
      }
    }
    close(fds[1]);
    // Every gait the child reported was committed (both transactions).
    std::vector<std::pair<std::int64_t, int>> committed;
    const int wanted = 30 + 20 * round;
    while (static_cast<int>(committed.size()) < wanted) {
      std::int64_t message[2];
      ASSERT_EQ(read(fds[0], message, sizeof message), static_cast<ssize_t>(sizeof message));
      committed.emplace_back(message[0], static_cast<int>(message[1]));
    }
    kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer failed with exit status " << WEXITSTATUS(status);
    close(fds[0]);

    GaitDatabase db(Path());  // integrity checked on open
    for (const auto& [id, i] : committed) {
      const auto found = db.Find(id);
      ASSERT_TRUE(found) << "gait " << id << " (write " << i << ") lost in round " << round;
      GaitRecord want = Numbered(i);
      want.id = id;
      want.use_count = 1;
      want.last_used = 100 + i;
      EXPECT_EQ(found->config_xml, want.config_xml);
      EXPECT_EQ(found->parameters, want.parameters);
      EXPECT_EQ(found->symptoms.defects, want.symptoms.defects);
      EXPECT_EQ(found->use_count, 1);
      EXPECT_DOUBLE_EQ(found->last_used, want.last_used);
    }
    // Each stored gait is whole: its parameters are all there.
    for (const GaitRecord& g : db.All()) EXPECT_EQ(g.parameters.size(), 20u) << "gait " << g.id;
  }
}

}  // namespace
}  // namespace yamor::lifelong
