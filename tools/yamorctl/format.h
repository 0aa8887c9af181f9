// Output of yamorctl: one-line proto3 JSON for scripts, readable text for
// people.
#pragma once

#include <string>

#include <google/protobuf/message.h>

#include "yamor/v1/host.pb.h"
#include "yamor/v1/lifelong.pb.h"

namespace yamor::yamorctl {

/// One-line proto3 JSON of `message`: field names as in the .proto, fields
/// at their default value included (so scripts always find every key).
std::string ToJson(const google::protobuf::Message& message);

/// "position (x, y, z) m at t=… s (source)" plus the orientation line.
std::string FormatPosition(const v1::RobotPositionResponse& response);

/// GetInfo as aligned "key  value" lines.
std::string FormatInfo(const v1::GetInfoResponse& response);

/// OpenSimulation: the opened modules and the central one.
std::string FormatOpened(const v1::OpenSimulationResponse& response);

/// ConnectRobot: links, time and frames.
std::string FormatConnected(const v1::ConnectRobotResponse& response);

/// GetServoAngles: one "module  angle rad" line each.
std::string FormatServoAngles(const v1::GetServoAnglesResponse& response);

/// GetAccelerometer: one line per sample (raw counts and m/s^2).
std::string FormatAccelerometer(const v1::GetAccelerometerResponse& response);
/// GetOrientation: up vector, tilt in degrees, upside down.
std::string FormatOrientation(const v1::GetOrientationResponse& response);

/// Evaluate: velocity, distance, final position, divergence, trajectory.
std::string FormatEvaluation(const v1::EvaluateResponse& response);

/// One WatchState update: time, position, velocity, then one line per event.
std::string FormatStateUpdate(const v1::StateUpdate& update);

/// A yamor-lifelong's status (`life`): state, velocities in cm/s, threshold,
/// counts, relearning progress, gait.
std::string FormatLifeStatus(const v1::LifeStatus& status);

/// One event of a life (`life --watch`): time, kind, state and the event's JSON.
std::string FormatLifeUpdate(const v1::LifeUpdate& update);

}  // namespace yamor::yamorctl
