// Reads a sensor board's raw accelerometer counts through a yamord (the
// serial backend's readback on a real robot, or a simulation), so chapter 4
// can be re-run on hardware: `yamor-characterize record` writes them as a
// logged CSV that `noise --input` and `moves --input` read.
#pragma once

#include <string>
#include <vector>

#include "tools/characterize/logged_csv.h"

namespace yamor::characterize {

/// What to record.
/// Thread-safety: plain value.
struct BoardRecording {
  std::string host = "127.0.0.1:2224";  ///< The yamord.
  int module_id = 0;                    ///< Real id of the module whose board is read.
  double seconds = 10;                  ///< Length [s of robot time].
  double sample_period = 0.01;          ///< The board's sampling period [s] (docs/snp.md 0x0A).
  double rpc_deadline = 10;             ///< Deadline of one call [s].
};

/// Records `recording.seconds` of readings from the module's board. The robot
/// must be connected with the module's UART on. On a simulation the world is
/// advanced 16 samples at a time (virtual-time Sleep) and each reply is
/// exactly the new samples, timed by the simulation; on a real robot the
/// latest 16 are read every 16 sample periods of the wall clock and timed by
/// the host's clock (a late reply can drop or repeat a few readings: say so in
/// the lab notes). A failed call throws by the rule of
/// optimizer-plugins/framework/host_rpc.h (naming the host and the module):
/// kUnavailable when the daemon is gone,
/// kFailedPrecondition when the board does not answer (UART off), kNotFound
/// for an unknown module, kInvalidArgument for bad settings.
std::vector<LoggedReading> RecordBoard(const BoardRecording& recording);

/// The readings as a logged CSV (header time,count_x,count_y,count_z).
std::string LoggedReadingsCsv(const std::vector<LoggedReading>& readings);

}  // namespace yamor::characterize
