#include "optimizer-plugins/lifelong/anomaly_monitor.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "common/format.h"
#include "common/status.h"

namespace yamor::lifelong {

void ValidateAnomalyOptions(const AnomalyOptions& options) {
  if (!(std::isfinite(options.threshold) && options.threshold > 0)) {
    throw Error(StatusCode::kInvalidArgument,
                "anomaly threshold " + FormatRounded(options.threshold) + " must be a positive number");
  }
  if (!(options.smoothing >= 0 && options.smoothing < 1)) {
    throw Error(StatusCode::kInvalidArgument,
                "EMA smoothing " + FormatRounded(options.smoothing) + " is outside [0, 1)");
  }
  if (!(std::isfinite(options.min_reference) && options.min_reference >= 0)) {
    throw Error(StatusCode::kInvalidArgument,
                "minimum reference velocity " + FormatRounded(options.min_reference) + " must be >= 0");
  }
  if (!(std::isfinite(options.noise_factor) && options.noise_factor >= 0)) {
    throw Error(StatusCode::kInvalidArgument,
                "noise factor " + FormatRounded(options.noise_factor) + " must be >= 0");
  }
  if (options.learn_windows < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "learning windows " + std::to_string(options.learn_windows) + " must be >= 1");
  }
  if (options.increase_confirmations < 1) {
    throw Error(StatusCode::kInvalidArgument, "increase confirmations " +
                                                  std::to_string(options.increase_confirmations) + " must be >= 1");
  }
  if (options.noisy_confirmations < 1) {
    throw Error(StatusCode::kInvalidArgument, "noisy-gait confirmations " +
                                                  std::to_string(options.noisy_confirmations) + " must be >= 1");
  }
  if (options.confirmations < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "anomaly confirmations " + std::to_string(options.confirmations) + " must be >= 1");
  }
}

const char* VerdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kInitialised: return "initialised";
    case Verdict::kLearning: return "learning";
    case Verdict::kNormal: return "normal";
    case Verdict::kSuspect: return "suspect";
    case Verdict::kIncrease: return "increase";
    case Verdict::kDrop: return "drop";
    case Verdict::kIncreaseAnomaly: return "increase_anomaly";
    case Verdict::kPhysicalChange: return "physical_change";
  }
  return "?";
}

bool IsAnomaly(Verdict verdict) {
  return verdict == Verdict::kDrop || verdict == Verdict::kIncreaseAnomaly ||
         verdict == Verdict::kPhysicalChange;
}

AnomalyMonitor::AnomalyMonitor(AnomalyOptions options) : options_(std::move(options)) {
  ValidateAnomalyOptions(options_);
}

double AnomalyMonitor::RuleThreshold() const {
  return options_.relative ? options_.threshold * std::max(std::fabs(ema_), options_.min_reference)
                           : options_.threshold;
}

double AnomalyMonitor::Threshold() const {
  if (!initialised_) return 0;
  return std::max(RuleThreshold(), options_.noise_factor * noise_);
}

Observation AnomalyMonitor::Observe(double velocity) {
  if (!std::isfinite(velocity)) {
    throw Error(StatusCode::kInvalidArgument, "measured velocity is not finite: " + FormatRounded(velocity));
  }
  Observation o;
  o.measured = velocity;
  o.before = ema_;
  if (!initialised_) {
    initialised_ = true;
    ema_ = velocity;
    seen_ = 1;
    noise_ = 0;
    pending_ = 0;
    o.verdict = Verdict::kInitialised;
    o.ema = ema_;
    o.threshold = Threshold();
    return o;
  }
  const double deviation = velocity - ema_;
  if (options_.noise_factor > 0 && seen_ < options_.learn_windows) {
    // Learning: v the mean of the windows so far, d the mean |deviation|.
    noise_ += (std::fabs(deviation) - noise_) / seen_;
    ++seen_;
    ema_ += (velocity - ema_) / seen_;
    o.verdict = Verdict::kLearning;
    o.ema = ema_;
    o.threshold = Threshold();
    return o;
  }
  ++seen_;
  const double t = Threshold();
  o.threshold = t;
  if (std::fabs(deviation) < t) {
    ema_ = options_.smoothing * ema_ + (1 - options_.smoothing) * velocity;
    if (options_.noise_factor > 0) {
      noise_ = options_.smoothing * noise_ + (1 - options_.smoothing) * std::fabs(deviation);
    }
    pending_ = 0;
    o.verdict = Verdict::kNormal;
    o.ema = ema_;
    return o;
  }
  // An out-of-band window counts in the noise at the band's edge: d learned
  // from in-band windows alone never sees the tail, shrinks, and narrows the
  // band until an erratic gait alarms on its own noise (the configured wheel,
  // world seed 3: two drops in 30 min); clipped at t, a real change cannot
  // blow it up either.
  if (options_.noise_factor > 0) noise_ = options_.smoothing * noise_ + (1 - options_.smoothing) * t;
  const int sign = deviation < 0 ? -1 : 1;
  pending_ = (pending_sign_ == sign) ? pending_ + 1 : 1;
  pending_sign_ = sign;
  // A rise must last: one fast window is noise more often than a better
  // ground, and taking it as the new level would make the next ordinary
  // window look like a drop.
  // Judged on the band that judged this window (t), not on d after the
  // update above.
  const bool noise_sets_band = t > RuleThreshold();
  const int needed =
      sign > 0 ? std::max(options_.confirmations, options_.increase_confirmations)
      : noise_sets_band ? std::max(options_.confirmations, options_.noisy_confirmations)
                        : options_.confirmations;
  if (pending_ < needed) {
    o.verdict = Verdict::kSuspect;
    o.ema = ema_;
    return o;
  }
  pending_ = 0;
  if (sign < 0) {
    o.verdict = Verdict::kDrop;
  } else if (options_.increase_is_anomaly) {
    o.verdict = Verdict::kIncreaseAnomaly;
  } else {
    o.verdict = Verdict::kIncrease;
    ema_ = velocity;  // the robot got better: expect the new level from now on
  }
  o.ema = ema_;
  return o;
}

Observation AnomalyMonitor::OnEvent(const std::string& kind) {
  Observation o;
  o.before = ema_;
  o.ema = ema_;
  o.threshold = Threshold();
  o.verdict = options_.physical_events.count(kind) ? Verdict::kPhysicalChange : Verdict::kNormal;
  if (o.verdict == Verdict::kPhysicalChange) o.event = kind;
  return o;
}

void AnomalyMonitor::Reset() {
  initialised_ = false;
  ema_ = 0;
  seen_ = 0;
  noise_ = 0;
  pending_ = 0;
  pending_sign_ = 0;
}

void AnomalyMonitor::Seed(double velocity) {
  if (!std::isfinite(velocity)) {
    throw Error(StatusCode::kInvalidArgument, "seed velocity is not finite: " + FormatRounded(velocity));
  }
  initialised_ = true;
  ema_ = velocity;
  seen_ = 1;
  noise_ = 0;
  pending_ = 0;
  pending_sign_ = 0;
}

}  // namespace yamor::lifelong
