// The IARRC car's controller, board-independent: between a vision computer (speed-and-steering
// setpoints over serial) and the car, with an RC transmitter (SBUS) that can take over or stop
// the car at any moment.
//
//   SBUS frames -> RC present? switches -+
//   host bytes -> setpoints (fresh?) ----+-> mode state machine -> manual: RC pulses
//   encoder counts -> speed -------------+                         autonomous: speed PID
//   battery ADC -> volts (cutoff) -------+                      -> brake/reverse FSM -> pulses
//
// Modes: Boot -> Disarmed; Disarmed -> Manual or Autonomous by the RC mode switch, once it has
// been seen at "off" since disarming; Manual <-> Autonomous by the switch; any mode -> Emergency
// by the RC stop switch; Manual/Autonomous -> Failsafe when the RC signal is lost (no good frame
// for kRcSignalTimeoutUs, or a failsafe frame), when the battery is below its cutoff, or, in
// Autonomous, when the host has been silent for kTimingFailsafeTimeoutUs. Every way out of
// Emergency and Failsafe goes through Disarmed (switch at "off"), except a host that comes back
// in Autonomous with a zero-speed setpoint, as an ESC car re-arms on neutral.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/brake_fsm.h"
#include "roar/clock.h"
#include "roar/control_parser.h"
#include "roar/protocol.h"
#include "roar/sbus.h"
#include "roar/servo_output.h"
#include "roar/signing.h"

namespace roar {

// Counts a quadrature encoder's A/B edges (x4 decoding): +1 or -1 per valid edge; an input
// where both lines changed at once is a missed edge and counted as an error.
class QuadratureDecoder {
 public:
  void update(bool a, bool b);
  int32_t count() const { return count_; }
  uint32_t errors() const { return errors_; }

 private:
  uint8_t last_ = 0;  // (a << 1) | b
  int32_t count_ = 0;
  uint32_t errors_ = 0;
};

// Speed from encoder counts: the counts over the last kWindow updates, over their time.
class SpeedEstimator {
 public:
  static const uint8_t kWindow = 4;  // updates averaged (at 100 Hz: 40 ms)

  explicit SpeedEstimator(uint32_t counts_per_m) : counts_per_m_(counts_per_m) {}
  void update(int32_t count, Micros now_us);
  int32_t speed_mm_s() const { return speed_mm_s_; }  // [mm/s]
  int64_t distance_mm() const;                        // [mm] since the first update, signed

 private:
  uint32_t counts_per_m_;
  int32_t counts_[kWindow] = {};
  Micros times_[kWindow] = {};
  uint8_t filled_ = 0, next_ = 0;
  int32_t first_count_ = 0, last_count_ = 0;
  int32_t speed_mm_s_ = 0;
};

// Gains in per mille, so that the controller needs no floating point (the core runs on chips
// without an FPU): output [us] = (ff * setpoint + kp * error + ki * integral + kd * d(error)/dt)
// / 1000, with speeds in mm/s, the integral in mm and d(error)/dt in mm/s^2.
struct PidGains {
  int32_t kp_pm;  // [us per m/s] = [0.001 us per mm/s]
  int32_t ki_pm;  // [us per m]
  int32_t kd_pm;  // [us per m/s^2]
  int32_t ff_pm;  // [us per m/s] of the setpoint itself (feed-forward)
};

// Speed PID: throttle pulse offset from neutral [us] for a speed error, within +-max_us. The
// integral does not wind up: it stops growing while the output is saturated in its direction.
class SpeedPid {
 public:
  SpeedPid(const PidGains& gains, int32_t max_us) : gains_(gains), max_us_(max_us) {}
  int32_t step(int32_t target_mm_s, int32_t measured_mm_s, DurationUs dt_us);
  void reset();
  const PidGains& gains() const { return gains_; }
  void set_gains(const PidGains& gains) { gains_ = gains; }
  int32_t integral_mm() const { return static_cast<int32_t>(integral_um_ / 1000); }

 private:
  int64_t output_milli(int32_t target, int32_t error, int64_t integral_um, int32_t derivative) const;

  PidGains gains_;
  int32_t max_us_;
  int64_t integral_um_ = 0;  // [um] integrated error
  int32_t last_error_ = 0;   // [mm/s]
  bool started_ = false;
};

// Battery: ADC counts -> millivolts through the board's divider; a warning below low_mv, a
// cutoff below cutoff_mv that holds until the voltage is back above cutoff_mv + hysteresis_mv.
struct BatteryConfig {
  uint32_t uv_per_count = 8862;  // [uV per ADC count]: 3.3 V / 4095 behind an 11:1 divider
  uint32_t low_mv = 10500;       // [mV] warning (3S LiPo, 3.5 V per cell)
  uint32_t cutoff_mv = 9900;     // [mV] neutral (3.3 V per cell)
  uint32_t hysteresis_mv = 300;  // [mV]
};

class BatteryMonitor {
 public:
  explicit BatteryMonitor(const BatteryConfig& config = BatteryConfig()) : config_(config) {}
  void update(uint16_t adc_counts);
  uint32_t millivolts() const { return mv_; }
  bool low() const { return measured_ && mv_ < config_.low_mv; }
  bool cutoff() const { return cutoff_; }

 private:
  BatteryConfig config_;
  uint32_t mv_ = 0;
  bool measured_ = false;
  bool cutoff_ = false;
};

// IarrcMode and IarrcFailsafe (with their TEL words) are wire facts: roar/protocol.h.
enum class ModeSwitch : uint8_t { Off = 0, Manual = 1, Autonomous = 2 };

struct IarrcConfig {
  // RC channels (0-based SBUS channels) and switch thresholds [us]
  uint8_t steering_channel = 0;
  uint8_t throttle_channel = 2;
  uint8_t mode_channel = 4;   // 3 positions: off, manual, autonomous
  uint8_t stop_channel = 5;   // 2 positions: run, emergency stop
  uint16_t switch_low_us = 1300;   // [us] mode below this: off
  uint16_t switch_high_us = 1700;  // [us] mode above this: autonomous; stop above this: stop
  uint32_t counts_per_m = 10240u * 1000u / 207u;  // encoder counts per metre: 10,240 per turn of a 66 mm wheel (207 mm)
  PidGains pid = {500, 400, 0, 110};  // tuned on the simulated IARRC car (roar step-response)
  int32_t pid_max_us = 500;  // [us] the PID's reach either side of neutral
  BatteryConfig battery;
  BrakeConfig brake;
  ChannelCalibration throttle;  // trim and end-points of the outputs, as on every car
  ChannelCalibration steering;
};

struct IarrcOutputs {
  uint16_t throttle_us;
  uint16_t steering_us;
  IarrcMode mode;
  IarrcFailsafe failsafe;
};

class IarrcController {
 public:
  explicit IarrcController(const IarrcConfig& config = IarrcConfig());

  // The RC task: one received SBUS byte.
  void sbus_byte(uint8_t byte, Micros now_us) { sbus_.feed(byte, now_us); }
  // The host task: one received serial byte (setpoints; control messages are refused).
  // Returns the parse result (the board glue prints ERR for the rejections).
  ParseResult host_byte(uint8_t byte, Micros now_us);
  // The car's key (signed control): set by the board from KEY lines on the host port.
  KeyStore& keys() { return keys_; }
  const KeyStore& keys() const { return keys_; }
  // The encoder: the latest count (the board's timer in encoder mode, or QuadratureDecoder).
  void encoder(int32_t count, Micros now_us) { speed_.update(count, now_us); }
  // The battery task: one ADC reading.
  void battery(uint16_t adc_counts) { battery_.update(adc_counts); }
  // The control task: the mode, then the pulses to output now. frames_started: see BrakeFsm.
  IarrcOutputs control(Micros now_us, uint32_t frames_started);

  IarrcMode mode() const { return mode_; }
  IarrcFailsafe failsafe() const { return failsafe_; }
  bool rc_present(Micros now_us) const;
  ModeSwitch mode_switch() const;
  bool stop_switch() const;
  const SpeedEstimator& speed() const { return speed_; }
  const BatteryMonitor& battery_monitor() const { return battery_; }
  const SbusDecoder& sbus() const { return sbus_; }
  SpeedPid& pid() { return pid_; }
  const SpeedPid& pid() const { return pid_; }
  const Setpoint& setpoint() const { return setpoint_; }

 private:
  void enter(IarrcMode mode, IarrcFailsafe why = IarrcFailsafe::None);
  void step_mode(Micros now_us);
  bool host_fresh(Micros now_us) const;

  IarrcConfig config_;
  SbusDecoder sbus_;
  ControlParser parser_;
  KeyStore keys_;
  SpeedEstimator speed_;
  SpeedPid pid_;
  BatteryMonitor battery_;
  BrakeFsm brake_;
  IarrcMode mode_ = IarrcMode::Boot;
  IarrcFailsafe failsafe_ = IarrcFailsafe::None;
  bool switch_seen_off_ = false;  // since disarming, the mode switch has been at off
  Setpoint setpoint_ = {0, proto::kControlNeutralUs};
  bool host_heard_ = false;
  bool host_rearm_ = false;  // a zero-speed setpoint arrived while failsafed for host silence
  Micros host_last_us_ = 0;
  Micros last_control_us_ = 0;
  bool controlled_ = false;
};


}  // namespace roar
