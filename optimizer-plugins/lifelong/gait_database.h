// The gait database of thesis 7.8.2: every gait the robot has walked with,
// keyed by its body (canonical morphology key), its orientation and the
// symptoms of the anomaly that led to it, so that a known situation (back on
// the old ground, turned over again) is recovered by trying stored gaits
// before any optimization. SQLite in WAL mode; every write is one
// transaction, so a kill at any moment loses nothing that was committed.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

struct sqlite3;

namespace yamor::lifelong {

/// The robot's orientation, from the central module's accelerometers.
enum class Orientation { kUpright, kUpsideDown };

/// "upright" or "upside_down".
const char* OrientationName(Orientation orientation);
/// The orientation named `name`; kInvalidArgument otherwise.
Orientation ParseOrientation(std::string_view name);

/// What the robot saw when an anomaly came (thesis 7.8.2, "symptoms").
struct Symptoms {
  /// What signalled it: "velocity_drop", "module_disconnected",
  /// "orientation", ... ("initial" for the gait the robot started with).
  std::string trigger;
  double velocity_before = 0;  ///< Expected velocity (the EMA) before it [m/s].
  double velocity_after = 0;   ///< Velocity of the window that signalled it [m/s].
  bool has_acceleration = false;  ///< The accelerometer fields are set.
  /// Mean specific force of the central module in its own frame [m/s²].
  std::array<double, 3> acceleration{};
  double acceleration_spread = 0;  ///< RMS deviation of the samples from that mean [m/s²].
  std::vector<std::string> defects;  ///< Known defects ("motor 3 limp", "module 5"), sorted.

  /// Relative drop (before − after) / |before|; 0 when before is 0.
  double Drop() const;

  friend bool operator==(const Symptoms&, const Symptoms&) = default;
};

/// One stored gait.
struct GaitRecord {
  std::int64_t id = 0;         ///< Row id (set by Insert).
  std::string morphology_key;  ///< cpg::MorphologyKey of the body it walks.
  Orientation orientation = Orientation::kUpright;  ///< Orientation it walks in.
  std::string config_xml;      ///< The whole robot configuration (canonical XML).
  /// The optimization configuration (robot plus rules) it was learned with,
  /// so a relearn from it optimizes the same parameters; "" when unknown.
  std::string problem_xml;
  /// The values of its free parameters, in the problem's order.
  std::vector<std::pair<std::string, double>> parameters;
  double expected_velocity = 0;  ///< Velocity it reached when stored or last used [m/s].
  double created = 0;            ///< Unix time it was stored [s].
  double last_used = 0;          ///< Unix time it was last chosen [s].
  std::int64_t use_count = 0;    ///< Times it was chosen (stored, recalled, restored).
  std::optional<std::int64_t> predecessor;  ///< The gait it replaced.
  Symptoms symptoms;             ///< The anomaly that led to it.
  std::string origin;            ///< "initial", "online", "model", "recalled"...
  /// Its window noise [m/s]: the anomaly monitor's d (mean absolute deviation
  /// of its measurement windows around the EMA) when it last walked; 0 while
  /// unknown. A recall trial is judged against it (LifeOptions::recall_*).
  double velocity_noise = 0;
  /// Windows `velocity_noise` was learned from (0 while unknown).
  std::int64_t noise_windows = 0;

  friend bool operator==(const GaitRecord&, const GaitRecord&) = default;
};

/// What an anomaly looks like, to find stored gaits for it.
struct GaitQuery {
  std::string morphology_key;  ///< The body now.
  Orientation orientation = Orientation::kUpright;  ///< The orientation now.
  Symptoms symptoms;           ///< What was seen.
  std::optional<std::int64_t> current;  ///< The gait that failed (left out of the answer).
  int limit = 10;              ///< At most this many gaits.
};

/// A stored gait with its likelihood for a query.
struct RankedGait {
  GaitRecord gait;          ///< The gait.
  double likelihood = 0;    ///< Score (higher first); see Likelihood().
  std::string reasons;      ///< Which terms contributed, for the event log.
};

/// The likelihood of `candidate` for `query` (a score, not a probability):
///   3.0 · [the known defects are the same]
/// + 2.0 · exp(−|Δdrop| / 0.25)          (relative velocity drop alike)
/// + 1.0 · exp(−|Δa| / 2 m/s²)           (mean acceleration alike; when both have it)
/// + 1.5 · min(1, switches + links)       (the robot went from the current gait to
///                                          it before, or one replaced the other)
/// + 0.5 · min(1, ln(1 + uses) / ln(101)) (a gait used often)
/// `switches` is how often the robot went from query.current to it (the
/// history of RecordUse), plus one when query.current replaced it; `links`
/// adds one when it replaced query.current. `reasons` (may be null) gets the
/// terms.
/// Thread-safety: a pure function.
double Likelihood(const GaitRecord& candidate, const GaitQuery& query, std::int64_t switches,
                  std::string* reasons = nullptr);

/// How a stored gait fared when tried.
enum class UseOutcome { kAccepted, kRejected };

/// The gait database, one SQLite file.
///
/// Schema versioned with PRAGMA user_version (kSchemaVersion) and marked with
/// PRAGMA application_id; a file of an older version is migrated in place
/// when opened (one transaction: a kill during it leaves the old version
/// whole), a file of a newer version is refused (kFailedPrecondition
/// naming the file and both versions), a file that is not a SQLite
/// database, is damaged, or belongs to another application is refused with
/// kDataLoss naming the file — never a crash. Journal in WAL mode with
/// synchronous=FULL; every write method is one transaction.
///
/// Thread safety: every method may be called from any thread; calls are
/// serialized by an internal mutex. Several processes may open the same
/// file (SQLite locking; a busy database is waited for up to 10 s).
class GaitDatabase {
 public:
  /// The schema this build writes and reads. Version 2 added each gait's
  /// window noise (velocity_noise, noise_windows); a version-1 file is
  /// migrated on open (both columns 0: unknown).
  static constexpr int kSchemaVersion = 2;

  /// Opens `path`, creating it (and the schema) when it does not exist and
  /// `create` is true. Throws kNotFound when it does not exist and `create`
  /// is false or its folder does not exist, kDataLoss / kFailedPrecondition
  /// as above.
  explicit GaitDatabase(const std::string& path, bool create = true);
  ~GaitDatabase();
  GaitDatabase(const GaitDatabase&) = delete;
  GaitDatabase& operator=(const GaitDatabase&) = delete;

  /// Stores `record` (its id is ignored; created and last_used default to
  /// now when 0) and returns its id. kInvalidArgument for an empty key or
  /// configuration, or a non-finite number; kNotFound for a predecessor
  /// that is not stored.
  std::int64_t Insert(const GaitRecord& record);

  /// Records that gait `id` was tried at `unix_time` after gait `previous`
  /// and reached `velocity`. An accepted gait's use count grows by one, its
  /// last use becomes `unix_time` and its expected velocity `velocity`.
  /// kNotFound for an unknown id.
  void RecordUse(std::int64_t id, double unix_time, double velocity,
                 std::optional<std::int64_t> previous, UseOutcome outcome);

  /// Sets the expected velocity of gait `id` (its first window after it was
  /// learned). kNotFound for an unknown id, kInvalidArgument when not finite.
  void SetExpectedVelocity(std::int64_t id, double velocity);

  /// Sets the window noise of gait `id` [m/s], the windows it was learned
  /// from and, when given, its expected velocity (the EMA the noise is
  /// measured around), in one transaction. kNotFound for an unknown id,
  /// kInvalidArgument for a noise that is negative or not finite, a negative
  /// window count or an expected velocity that is not finite.
  void SetNoise(std::int64_t id, double noise, std::int64_t windows,
                std::optional<double> expected_velocity = std::nullopt);

  /// The gait with `id`, or nullopt.
  std::optional<GaitRecord> Find(std::int64_t id) const;
  /// A stored gait for the same body and orientation with exactly this
  /// configuration, or nullopt (to avoid storing a gait twice).
  std::optional<GaitRecord> FindSame(const std::string& morphology_key, Orientation orientation,
                                     const std::string& config_xml) const;
  /// Every gait, by id.
  std::vector<GaitRecord> All() const;
  /// The gaits stored for the query's body and orientation, except the
  /// current one, most likely first (ties: most recently used, then lowest id).
  std::vector<RankedGait> Match(const GaitQuery& query) const;
  /// Switches recorded from gait `from` to gait `to` (accepted uses).
  std::int64_t Switches(std::int64_t from, std::int64_t to) const;

  /// The file.
  const std::string& path() const { return path_; }

 private:
  // Brings an older schema to kSchemaVersion (constructor only).
  void Migrate();
  GaitRecord ReadLocked(std::int64_t id) const;
  std::vector<std::int64_t> IdsLocked(const std::string& sql, const std::vector<std::string>& args) const;

  std::string path_;
  mutable std::mutex mu_;
  sqlite3* db_ = nullptr;  // guarded by mu_
};

}  // namespace yamor::lifelong
