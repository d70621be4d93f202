#include "roar/iarrc_board.h"

#include "roar/text.h"

namespace roar {

// Costs: each task body's worst input counted in Cortex-M4 instructions in QEMU
// (hil_sim/stm32/task_bench.cpp: 64 SBUS bytes, 64 setpoint bytes, a PID command and a telemetry
// line), at one cycle per instruction on the F745 at 16 MHz (the glue's clock), plus a quarter,
// plus the gyro's SPI transfer and the battery's ADC conversion. tests/firmware/test_stm32_emulator.py
// keeps them above the measurement.
const TaskSpec kIarrcTasks[kIarrcTaskCount] = {
    {"rc", 2000, 5, 256, 420},
    {"control", 10000, 4, 512, 60},
    {"host", 5000, 3, 384, 600},  // (KEY lines and signed setpoints read on this port)
    {"gyro", 5000, 2, 256, 60},
    {"telemetry", 100000, 2, 512, 250},
    {"battery", 500000, 1, 256, 100},
};

namespace {

class Locked {
 public:
  explicit Locked(IarrcHal& hal) : hal_(hal) { hal_.lock(); }
  ~Locked() { hal_.unlock(); }

 private:
  IarrcHal& hal_;
};

// MPU6000 at +-2000 deg/s: 16.4 counts per deg/s -> mdeg/s = raw * 10000 / 164
int32_t gyro_mdeg_s(int16_t raw) { return static_cast<int32_t>(raw) * 10000 / 164; }

// Parses "PID KP KI KD FF": four decimal integers in 0..kTelemetryMaxGainPm.
bool parse_gains(const char* text, size_t n, PidGains* gains) {
  const size_t word = sizeof(proto::kTelemetrySetGains) - 1;
  if (n <= word || !equals(text, word, proto::kTelemetrySetGains) || text[word] != ' ') return false;
  int32_t values[4];
  size_t i = word;
  for (int32_t& v : values) {
    if (i >= n || text[i] != ' ') return false;
    ++i;
    if (i >= n || text[i] < '0' || text[i] > '9') return false;
    uint32_t value = 0;
    for (; i < n && text[i] >= '0' && text[i] <= '9'; ++i) {
      value = value * 10u + static_cast<uint32_t>(text[i] - '0');
      if (value > proto::kTelemetryMaxGainPm) return false;
    }
    v = static_cast<int32_t>(value);
  }
  if (i != n) return false;
  *gains = PidGains{values[0], values[1], values[2], values[3]};
  return true;
}

}  // namespace

void IarrcBoard::begin() {
  char line[16];
  size_t n = 0;
  append(line, sizeof(line), &n, proto::kSerialReplyReady);
  append(line, sizeof(line), &n, " ");
  append_uint(line, sizeof(line), &n, proto::kMetaSpeedVersion);
  append(line, sizeof(line), &n, proto::kSerialReplyLineEnd);
  hal_.write_host(line, n);
  char session[proto::kSerialMaxReplyBytes + 1];
  n = 0;
  {
    Locked locked(hal_);
    controller_.keys().boot(hal_.nvm());
    if (controller_.keys().auth().keyed()) append_session_reply(session, sizeof(session), &n, controller_.keys().auth());
  }
  if (n) hal_.write_host(session, n);
}

void IarrcBoard::host_key_line(KeyLine::Event ev) {
  char line[2 * proto::kSerialMaxReplyBytes + 1];  // KEY and SESSION
  size_t n = 0;
  {
    Locked locked(hal_);
    n = controller_.keys().on_key_line(ev, key_line_.key(), line, sizeof(line));
  }
  if (n) hal_.write_host(line, n);
}

void IarrcBoard::run(IarrcTask task) {
  switch (task) {
    case IarrcTask::Rc: return run_rc();
    case IarrcTask::Control: return run_control();
    case IarrcTask::Host: return run_host();
    case IarrcTask::Gyro: return run_gyro();
    case IarrcTask::Telemetry: return run_telemetry();
    case IarrcTask::Battery: return run_battery();
  }
}

void IarrcBoard::overran(IarrcTask, uint32_t missed) {
  Locked locked(hal_);
  overruns_ += missed;
}

void IarrcBoard::run_rc() {
  Locked locked(hal_);
  const RawMicros raw_now = hal_.now_us();
  const Micros t = clock_.extend(raw_now);
  uint8_t byte;
  RawMicros at;
  for (uint8_t i = 0; i < kMaxBytesPerRun && hal_.read_sbus(&byte, &at); ++i) {
    // The byte's age on the wrapping counter; one stamped after raw_now was read is new.
    const RawMicros age = raw_now - at;
    controller_.sbus_byte(byte, age > 0x7FFFFFFFu || age > t ? t : t - age);
  }
  ++rc_runs_;
}

void IarrcBoard::run_control() {
  const char* say = nullptr;
  {
    Locked locked(hal_);
    const Micros t = now();
    const IarrcMode before = outputs_.mode;
    controller_.encoder(hal_.encoder_count(), t);
    outputs_ = controller_.control(t, hal_.frames_started());
    if (outputs_.mode != before && outputs_.mode == IarrcMode::Failsafe) say = proto::kSerialReplyFailsafe;
    if (outputs_.mode == IarrcMode::Autonomous && before == IarrcMode::Failsafe) say = proto::kSerialReplyArmed;
  }
  hal_.write_pulses(outputs_.throttle_us, outputs_.steering_us);
  if (say) {
    char line[16];
    size_t n = 0;
    append(line, sizeof(line), &n, say);
    append(line, sizeof(line), &n, proto::kSerialReplyLineEnd);
    hal_.write_host(line, n);
  }
  if (rc_runs_ != rc_runs_at_feed_) {  // the RC task has run since the last feed
    rc_runs_at_feed_ = rc_runs_;
    hal_.feed_watchdog();
  }
}

void IarrcBoard::run_host() {
  for (uint8_t i = 0; i < kMaxBytesPerRun; ++i) {
    const int byte = hal_.read_host();
    if (byte < 0) break;
    const KeyLine::Event ev = key_line_.feed(static_cast<uint8_t>(byte));
    if (ev != KeyLine::Event::NotMine) {
      if (ev != KeyLine::Event::Taken) host_key_line(ev);
      if (ev != KeyLine::Event::Bad) continue;
    }
    ParseResult r;
    uint32_t value = 0;  // the session or the last counter, after a signing refusal
    {
      Locked locked(hal_);
      r = controller_.host_byte(static_cast<uint8_t>(byte), now());
      value = refusal_value(r, controller_.keys().auth());
    }
    if (r == ParseResult::None || r == ParseResult::Setpoint) continue;
    char line[proto::kSerialMaxReplyBytes + 1];
    size_t n = 0;
    append(line, sizeof(line), &n, proto::kSerialReplyError);
    append(line, sizeof(line), &n, " ");
    if (r == ParseResult::Ok) {  // a (THROTTLE,STEERING) message is valid but not what this board drives by
      append(line, sizeof(line), &n, proto::kSerialErrorUnsupported);
    } else {
      append_refusal(line, sizeof(line), &n, r, value);
    }
    append(line, sizeof(line), &n, proto::kSerialReplyLineEnd);
    hal_.write_host(line, n);
  }
}

void IarrcBoard::run_gyro() {
  const int32_t rate = gyro_mdeg_s(hal_.gyro_z_raw());
  Locked locked(hal_);
  yaw_rate_mdeg_s_ = rate;
}

void IarrcBoard::run_battery() {
  const uint16_t adc = hal_.battery_adc();
  Locked locked(hal_);
  controller_.battery(adc);
}

void IarrcBoard::write_both(const char* text, size_t length) {
  hal_.write_host(text, length);
  hal_.write_link(text, length);
}

void IarrcBoard::link_command() {
  PidGains gains;
  if (command_overflow_) {
    const char reply[] = "ERR too_long\n";
    hal_.write_link(reply, sizeof(reply) - 1);
  } else if (parse_gains(command_, command_len_, &gains)) {
    Locked locked(hal_);
    controller_.pid().set_gains(gains);
  } else if (command_len_ > 0) {
    const char reply[] = "ERR syntax\n";
    hal_.write_link(reply, sizeof(reply) - 1);
  }
  command_len_ = 0;
  command_overflow_ = false;
}

void IarrcBoard::run_telemetry() {
  for (uint8_t i = 0; i < kMaxBytesPerRun; ++i) {
    const int byte = hal_.read_link();
    if (byte < 0) break;
    if (byte == '\n') {
      link_command();
    } else if (byte != '\r') {
      if (command_len_ < sizeof(command_) - 1) {
        command_[command_len_++] = static_cast<char>(byte);
      } else {
        command_overflow_ = true;
      }
    }
  }
  char line[proto::kTelemetryMaxLineBytes + 1];
  size_t n;
  {
    Locked locked(hal_);
    n = telemetry_line(line, sizeof(line) - 1);
  }
  line[n++] = '\n';
  write_both(line, n);
}

size_t IarrcBoard::telemetry_line(char* out, size_t cap) const {
  const IarrcController& c = controller_;
  const PidGains& g = c.pid().gains();
  const int64_t distance = c.speed().distance_mm();
  const int32_t distance_mm = distance > 0x7FFFFFFF ? 0x7FFFFFFF : (distance < -0x7FFFFFFF ? -0x7FFFFFFF : static_cast<int32_t>(distance));
  size_t n = 0;
  append(out, cap, &n, proto::kTelemetryReply);
  append(out, cap, &n, " ");
  append(out, cap, &n, iarrc_mode_token(outputs_.mode));
  append(out, cap, &n, " ");
  append(out, cap, &n, iarrc_failsafe_token(outputs_.failsafe));
  const int32_t numbers[] = {static_cast<int32_t>(c.battery_monitor().millivolts()),
                             c.battery_monitor().low() ? 1 : 0,
                             distance_mm,
                             c.speed().speed_mm_s(),
                             c.setpoint().speed_mm_s,
                             outputs_.throttle_us,
                             outputs_.steering_us,
                             yaw_rate_mdeg_s_,
                             g.kp_pm,
                             g.ki_pm,
                             g.kd_pm,
                             g.ff_pm,
                             static_cast<int32_t>(overruns_)};
  for (int32_t v : numbers) {
    append(out, cap, &n, " ");
    append_int(out, cap, &n, v);
  }
  return n;
}

}  // namespace roar
