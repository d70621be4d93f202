// extern "C" wrappers over the core and the host board (memory_boards.h), and nothing else.
// Placement new puts each object in the caller's memory; the objects are trivially
// destructible, so no destroy call is needed.
#include "c_api.h"

#include <new>

#include "memory_boards.h"
#include "roar/http_request.h"
#include "roar/iarrc.h"
#include "roar/junior_control.h"
#include "roar/l298n_driver.h"
#include "roar/sbus.h"
#include "roar/signing.h"
#include "roar/siphash.h"

using namespace roar;

namespace {

template <typename T>
T* as(void* p) {
  return static_cast<T*>(p);
}
template <typename T>
const T* as(const void* p) {
  return static_cast<const T*>(p);
}

}  // namespace

// Every code of c_api.h's enums is the core's own (tests/firmware/test_c_abi.py checks that each enum
// is listed here whole).
#define ROAR_SAME_CODE(cxx, c) static_assert(static_cast<int>(cxx) == (c), #c " in c_api.h differs from " #cxx)
ROAR_SAME_CODE(WatchdogEvent::None, ROAR_WATCHDOG_EVENT_NONE);
ROAR_SAME_CODE(WatchdogEvent::Tripped, ROAR_WATCHDOG_EVENT_TRIPPED);
ROAR_SAME_CODE(WatchdogEvent::Armed, ROAR_WATCHDOG_EVENT_ARMED);
ROAR_SAME_CODE(BrakePhase::NeedsSequence, ROAR_BRAKE_PHASE_NEEDS_SEQUENCE);
ROAR_SAME_CODE(BrakePhase::Neutral1, ROAR_BRAKE_PHASE_NEUTRAL1);
ROAR_SAME_CODE(BrakePhase::Tap, ROAR_BRAKE_PHASE_TAP);
ROAR_SAME_CODE(BrakePhase::Neutral2, ROAR_BRAKE_PHASE_NEUTRAL2);
ROAR_SAME_CODE(BrakePhase::ReverseReady, ROAR_BRAKE_PHASE_REVERSE_READY);
ROAR_SAME_CODE(ControlSource::Failsafe, ROAR_CONTROL_SOURCE_FAILSAFE);
ROAR_SAME_CODE(ControlSource::Host, ROAR_CONTROL_SOURCE_HOST);
ROAR_SAME_CODE(ControlSource::Rc, ROAR_CONTROL_SOURCE_RC);
ROAR_SAME_CODE(RcChannel::Throttle, ROAR_RC_CHANNEL_THROTTLE);
ROAR_SAME_CODE(RcChannel::Steering, ROAR_RC_CHANNEL_STEERING);
ROAR_SAME_CODE(HttpRead::Incomplete, ROAR_HTTP_READ_INCOMPLETE);
ROAR_SAME_CODE(HttpRead::Complete, ROAR_HTTP_READ_COMPLETE);
ROAR_SAME_CODE(HttpRead::Malformed, ROAR_HTTP_READ_MALFORMED);
ROAR_SAME_CODE(HttpRead::TooLong, ROAR_HTTP_READ_TOO_LONG);
ROAR_SAME_CODE(JuniorQueryError::None, ROAR_JUNIOR_QUERY_ERROR_NONE);
ROAR_SAME_CODE(JuniorQueryError::UnknownName, ROAR_JUNIOR_QUERY_ERROR_UNKNOWN_NAME);
ROAR_SAME_CODE(JuniorQueryError::BadFlag, ROAR_JUNIOR_QUERY_ERROR_BAD_FLAG);
ROAR_SAME_CODE(JuniorQueryError::BadSpeed, ROAR_JUNIOR_QUERY_ERROR_BAD_SPEED);
ROAR_SAME_CODE(ModeSwitch::Off, ROAR_MODE_SWITCH_OFF);
ROAR_SAME_CODE(ModeSwitch::Manual, ROAR_MODE_SWITCH_MANUAL);
ROAR_SAME_CODE(ModeSwitch::Autonomous, ROAR_MODE_SWITCH_AUTONOMOUS);
ROAR_SAME_CODE(IarrcTask::Rc, ROAR_IARRC_TASK_RC);
ROAR_SAME_CODE(IarrcTask::Control, ROAR_IARRC_TASK_CONTROL);
ROAR_SAME_CODE(IarrcTask::Host, ROAR_IARRC_TASK_HOST);
ROAR_SAME_CODE(IarrcTask::Gyro, ROAR_IARRC_TASK_GYRO);
ROAR_SAME_CODE(IarrcTask::Telemetry, ROAR_IARRC_TASK_TELEMETRY);
ROAR_SAME_CODE(IarrcTask::Battery, ROAR_IARRC_TASK_BATTERY);

extern "C" {

uint32_t roar_core_abi_version(void) { return ROAR_CORE_ABI_VERSION; }
uint32_t roar_protocol_version(void) { return proto::kMetaProtocolVersion; }

size_t roar_parser_size(void) { return sizeof(ControlParser); }
void roar_parser_init(void* parser) { new (parser) ControlParser(); }

uint8_t roar_parser_feed(void* parser, uint8_t byte, uint16_t* throttle, uint16_t* steering) {
  ControlParser* p = as<ControlParser>(parser);
  const ParseResult r = p->feed(byte);
  if (r == ParseResult::Ok) {
    *throttle = p->command().throttle_us;
    *steering = p->command().steering_us;
  }
  return static_cast<uint8_t>(r);
}

size_t roar_parser_feed_buffer(void* parser, const uint8_t* data, size_t n, roar_parse_event_t* events,
                               size_t max_events) {
  ControlParser* p = as<ControlParser>(parser);
  size_t count = 0;
  for (size_t i = 0; i < n; ++i) {
    const ParseResult r = p->feed(data[i]);
    if (r == ParseResult::None) continue;
    if (count < max_events) {
      roar_parse_event_t& e = events[count];
      e = roar_parse_event_t{};
      e.at = static_cast<uint32_t>(i);
      e.result = static_cast<uint8_t>(r);
      if (r == ParseResult::Ok) {
        e.throttle = p->command().throttle_us;
        e.steering = p->command().steering_us;
      } else if (r == ParseResult::Setpoint) {
        e.speed_mm_s = p->setpoint().speed_mm_s;
        e.steering = p->setpoint().steering_us;
      }
      if (r == ParseResult::Ok || r == ParseResult::Setpoint) {
        if (p->signature().present) {
          e.is_signed = 1;
          e.counter = p->signature().counter;
          e.mac = p->signature().mac;
        }
      }
    }
    ++count;
  }
  return count;
}

size_t roar_watchdog_size(void) { return sizeof(CommandWatchdog); }
void roar_watchdog_init(void* wd, uint32_t timeout_us) { new (wd) CommandWatchdog(timeout_us); }
int roar_watchdog_accept(void* wd, uint16_t throttle, uint16_t steering, uint64_t now_us, uint8_t* event) {
  WatchdogEvent ev = WatchdogEvent::None;
  const bool ok = as<CommandWatchdog>(wd)->accept(ControlCommand{throttle, steering}, now_us, &ev);
  if (event) *event = static_cast<uint8_t>(ev);
  return ok ? 1 : 0;
}
uint8_t roar_watchdog_poll(void* wd, uint64_t now_us) {
  return static_cast<uint8_t>(as<CommandWatchdog>(wd)->poll(now_us));
}
int roar_watchdog_latched(const void* wd) { return as<CommandWatchdog>(wd)->latched() ? 1 : 0; }

size_t roar_brake_size(void) { return sizeof(BrakeFsm); }
void roar_brake_init(void* fsm, uint16_t neutral_us, uint16_t tap_us, uint32_t step_us) {
  BrakeConfig cfg;
  cfg.neutral_us = neutral_us;
  cfg.tap_us = tap_us;
  cfg.step_us = step_us;
  new (fsm) BrakeFsm(cfg);
}
uint16_t roar_brake_step(void* fsm, uint16_t command_us, uint64_t now_us, uint32_t frames_started) {
  return as<BrakeFsm>(fsm)->step(command_us, now_us, frames_started);
}
uint8_t roar_brake_phase(const void* fsm) { return static_cast<uint8_t>(as<BrakeFsm>(fsm)->phase()); }

static ChannelCalibration calibration(int16_t trim_us, uint16_t min_us, uint16_t max_us) {
  ChannelCalibration cal;
  cal.trim_us = trim_us;
  cal.min_us = min_us;
  cal.max_us = max_us;
  return cal;
}
uint16_t roar_map_pulse(uint16_t command_us, int16_t trim_us, uint16_t min_us, uint16_t max_us) {
  return map_pulse(command_us, calibration(trim_us, min_us, max_us));
}
int roar_calibration_valid(int16_t trim_us, uint16_t min_us, uint16_t max_us) {
  return calibration_valid(calibration(trim_us, min_us, max_us)) ? 1 : 0;
}

size_t roar_rc_size(void) { return sizeof(RcOverride); }
void roar_rc_init(void* rc) { new (rc) RcOverride(); }
void roar_rc_pulse(void* rc, uint8_t channel, uint16_t width_us, uint64_t now_us) {
  as<RcOverride>(rc)->on_pulse(static_cast<RcChannel>(channel & 1u), width_us, now_us);
}
int roar_rc_active(const void* rc, uint64_t now_us) { return as<RcOverride>(rc)->active(now_us) ? 1 : 0; }
void roar_rc_command(const void* rc, uint16_t* throttle, uint16_t* steering) {
  const ControlCommand c = as<RcOverride>(rc)->command();
  *throttle = c.throttle_us;
  *steering = c.steering_us;
}

size_t roar_l298n_size(void) { return sizeof(L298nDriver); }
void roar_l298n_init(void* drv, uint32_t dead_time_us) { new (drv) L298nDriver(dead_time_us); }
void roar_l298n_step(void* drv, int16_t left, int16_t right, uint64_t now_us, roar_side_pins_t* left_out,
                     roar_side_pins_t* right_out) {
  const DrivePins pins = as<L298nDriver>(drv)->step(SideDuties{left, right}, now_us);
  *left_out = to_c(pins.left);
  *right_out = to_c(pins.right);
}

size_t roar_junior_size(void) { return sizeof(JuniorControl); }
void roar_junior_init(void* junior) { new (junior) JuniorControl(); }
int roar_junior_apply_query(void* junior, const char* query, size_t n, uint64_t now_us) {
  const JuniorQueryResult r = as<JuniorControl>(junior)->apply_query(query, n, now_us);
  return r.error == JuniorQueryError::None ? r.applied : -static_cast<int>(r.error);
}
void roar_junior_duties(const void* junior, uint64_t now_us, int16_t* left, int16_t* right) {
  const SideDuties d = as<JuniorControl>(junior)->duties(now_us);
  *left = d.left;
  *right = d.right;
}

void roar_car_default_config(roar_car_config_t* c) {
  const CarConfig d;
  *c = roar_car_config_t{d.failsafe_timeout_us, d.brake.step_us, d.brake.tap_us,
                         d.throttle.trim_us, d.throttle.min_us, d.throttle.max_us,
                         d.steering.trim_us, d.steering.min_us, d.steering.max_us,
                         d.failsafe_enabled, d.brake_fsm_enabled, d.rc_override_enabled, {0, 0, 0}};
}

size_t roar_car_size(void) { return sizeof(Car); }

static CarConfig car_config(const roar_car_config_t* c) {
  CarConfig cfg;
  cfg.failsafe_timeout_us = c->failsafe_timeout_us;
  cfg.brake.step_us = c->brake_step_us;
  cfg.brake.tap_us = c->brake_tap_us;
  cfg.throttle = calibration(c->throttle_trim_us, c->throttle_min_us, c->throttle_max_us);
  cfg.steering = calibration(c->steering_trim_us, c->steering_min_us, c->steering_max_us);
  cfg.failsafe_enabled = c->failsafe_enabled != 0;
  cfg.brake_fsm_enabled = c->brake_fsm_enabled != 0;
  cfg.rc_override_enabled = c->rc_override_enabled != 0;
  return cfg;
}
static bool config_valid(const CarConfig& cfg) {
  return calibration_valid(cfg.throttle) && calibration_valid(cfg.steering);
}

int roar_car_init(void* car, const roar_car_config_t* c) {
  const CarConfig cfg = car_config(c);
  if (!config_valid(cfg)) return -1;
  new (car) Car(cfg);
  return 0;
}

void roar_car_boot(void* car) { as<Car>(car)->boot(); }
void roar_car_feed(void* car, const uint8_t* data, size_t n, uint64_t now_us) {
  as<Car>(car)->feed(data, n, now_us);
}
void roar_car_rc_pulse(void* car, uint8_t channel, uint16_t width_us, uint64_t now_us) {
  as<Car>(car)->rc_pulse(static_cast<RcChannel>(channel & 1u), width_us, now_us);
}
void roar_car_step(void* car, uint64_t now_us, uint32_t frames_started, roar_car_outputs_t* out) {
  Car* c = as<Car>(car);
  *out = to_c(c->step(now_us, frames_started), *c);
}
size_t roar_car_take_reply(void* car, char* buf, size_t cap) { return as<Car>(car)->take_reply(buf, cap); }


size_t roar_board_size(void) { return sizeof(HostCarBoard); }

int roar_board_init(void* board, roar_host_hal_t* hal, const roar_car_config_t* c) {
  const CarConfig cfg = car_config(c);
  if (!config_valid(cfg)) return -1;
  new (board) HostCarBoard(hal, cfg);
  return 0;
}
void roar_board_begin(void* board) { as<HostCarBoard>(board)->board.begin(); }
void roar_board_feed(void* board, const uint8_t* data, size_t n) { as<HostCarBoard>(board)->board.feed(data, n); }
void roar_board_run(void* board, uint32_t loops) { as<HostCarBoard>(board)->run(loops); }
void roar_boards_run(void* boards, roar_host_hal_t* hals, size_t n, const uint8_t* run, const uint16_t* throttle_us,
                     const uint16_t* steering_us, uint32_t loops, uint16_t* wire_us) {
  const size_t size = sizeof(HostCarBoard);
  for (size_t i = 0; i < n; ++i) {
    if (run && !run[i]) continue;
    HostCarBoard* board = as<HostCarBoard>(static_cast<uint8_t*>(boards) + i * size);
    roar_host_hal_t* m = &hals[i];
    if (throttle_us[i]) serial_control(m, throttle_us[i], steering_us[i]);
    for (uint32_t k = 0; k < loops; ++k) {
      board->run(1);
      wire_us[(k * n + i) * 2] = m->wire_us[0];
      wire_us[(k * n + i) * 2 + 1] = m->wire_us[1];
    }
    m->tx_len = 0;
  }
}
uint32_t roar_board_session(const void* board) {
  return static_cast<const HostCarBoard*>(board)->board.car().auth().session();
}
uint32_t roar_board_last_counter(const void* board) {
  return static_cast<const HostCarBoard*>(board)->board.car().auth().last_counter();
}


size_t roar_junior_board_size(void) { return sizeof(HostJuniorBoard); }
void roar_junior_board_init(void* board, roar_junior_hal_t* hal) { new (board) HostJuniorBoard(hal); }
void roar_junior_board_run(void* board, uint32_t loops) { as<HostJuniorBoard>(board)->run(loops); }
void roar_junior_board_begin(void* board) { as<HostJuniorBoard>(board)->board.begin(); }
uint32_t roar_junior_board_session(const void* board) {
  return static_cast<const HostJuniorBoard*>(board)->board.auth().session();
}
size_t roar_junior_board_respond(void* board, const void* reader, char* out, size_t cap, uint8_t* keep_open) {
  HostJuniorBoard* j = as<HostJuniorBoard>(board);
  bool keep = false;
  const size_t n = j->board.respond(*as<HttpRequestReader>(reader), j->hal.memory().distance_cm, out, cap, &keep);
  *keep_open = keep ? 1 : 0;
  return n;
}
size_t roar_junior_reply_max(void) { return JuniorBoard::kMaxReplyBytes; }

size_t roar_http_reader_size(void) { return sizeof(HttpRequestReader); }
void roar_http_reader_init(void* reader) { new (reader) HttpRequestReader(); }
size_t roar_http_reader_feed(void* reader, const uint8_t* data, size_t n, uint8_t* state) {
  HttpRequestReader* r = as<HttpRequestReader>(reader);
  size_t used = 0;
  HttpRead s = r->state();
  while (used < n && s == HttpRead::Incomplete) s = r->feed(data[used++]);
  *state = static_cast<uint8_t>(s);
  return used;
}
const char* roar_http_reader_path(const void* reader, size_t* length) {
  const HttpRequestReader* r = as<HttpRequestReader>(reader);
  *length = r->path_length();
  return r->path();
}
size_t roar_http_refuse(const void* reader, char* out, size_t cap) {
  return JuniorBoard::refuse(*as<HttpRequestReader>(reader), out, cap);
}

}  // extern "C"

namespace {
// SbusFrame and roar_sbus_frame_t have the same fields; copy them either way.
template <typename From, typename To>
To copy_frame(const From& f) {
  To out = {};
  for (uint8_t i = 0; i < kSbusChannels; ++i) out.raw[i] = f.raw[i];
  out.ch17 = f.ch17;
  out.ch18 = f.ch18;
  out.frame_lost = f.frame_lost;
  out.failsafe = f.failsafe;
  out.end = f.end;
  return out;
}
SbusFrame from_c(const roar_sbus_frame_t& f) { return copy_frame<roar_sbus_frame_t, SbusFrame>(f); }
roar_sbus_frame_t to_c(const SbusFrame& f) { return copy_frame<SbusFrame, roar_sbus_frame_t>(f); }

void iarrc_status(const IarrcController& c, const IarrcOutputs& o, Micros now_us, roar_iarrc_status_t* out) {
  *out = roar_iarrc_status_t{};
  out->throttle_us = o.throttle_us;
  out->steering_us = o.steering_us;
  out->mode = static_cast<uint8_t>(o.mode);
  out->failsafe = static_cast<uint8_t>(o.failsafe);
  out->rc_present = c.rc_present(now_us);
  out->mode_switch = static_cast<uint8_t>(c.mode_switch());
  out->speed_mm_s = c.speed().speed_mm_s();
  out->setpoint_mm_s = c.setpoint().speed_mm_s;
  out->distance_mm = c.speed().distance_mm();
  out->battery_mv = c.battery_monitor().millivolts();
  out->battery_low = c.battery_monitor().low();
  out->battery_cutoff = c.battery_monitor().cutoff();
  out->pid_integral_mm = c.pid().integral_mm();
}

}  // namespace

extern "C" {
void roar_sbus_encode(const roar_sbus_frame_t* frame, uint8_t* out) { sbus_encode(from_c(*frame), out); }
int roar_sbus_decode(const uint8_t* in, roar_sbus_frame_t* frame) {
  SbusFrame f;
  if (!sbus_decode(in, &f)) return 0;
  *frame = to_c(f);
  return 1;
}
size_t roar_sbus_decoder_size(void) { return sizeof(SbusDecoder); }
void roar_sbus_decoder_init(void* decoder) { new (decoder) SbusDecoder(); }
uint8_t roar_sbus_feed(void* decoder, uint8_t byte, uint64_t now_us) {
  return static_cast<uint8_t>(as<SbusDecoder>(decoder)->feed(byte, now_us));
}
void roar_sbus_last_frame(const void* decoder, roar_sbus_frame_t* frame) {
  *frame = to_c(static_cast<const SbusDecoder*>(decoder)->frame());
}
uint64_t roar_message_mac(const uint8_t* key, uint32_t session, uint8_t start, int16_t first, uint16_t steering,
                          uint32_t counter) {
  return message_mac(key, session, start, first, steering, counter);
}
uint32_t roar_key_fingerprint(const uint8_t* key) { return key_fingerprint(key); }
size_t roar_auth_size(void) { return sizeof(Authenticator); }
void roar_auth_init(void* auth) { new (auth) Authenticator(); }
void roar_auth_set_key(void* auth, const uint8_t* key, uint32_t session) { as<Authenticator>(auth)->set_key(key, session); }
uint8_t roar_auth_check(void* auth, uint8_t kind, const void* parser) {
  return static_cast<uint8_t>(
      as<Authenticator>(auth)->check(static_cast<ParseResult>(kind), *static_cast<const ControlParser*>(parser)));
}
uint32_t roar_auth_last_counter(const void* auth) { return static_cast<const Authenticator*>(auth)->last_counter(); }

uint64_t roar_siphash24(const uint8_t* key, const uint8_t* data, size_t n) {
  return roar::SipHash24::mac(key, data, n);
}

void roar_sbus_status(const void* decoder, roar_sbus_status_t* status) {
  const SbusDecoder* d = static_cast<const SbusDecoder*>(decoder);
  *status = roar_sbus_status_t{};
  status->locked = d->locked();
  status->good_frames = d->good_frames();
  status->lost_frames = d->lost_frames();
  status->failsafe_frames = d->failsafe_frames();
  status->dropped = d->dropped();
  status->last_good_us = d->last_good_us();
}

size_t roar_iarrc_size(void) { return sizeof(IarrcController); }
void roar_iarrc_init(void* controller) { new (controller) IarrcController(); }
void roar_iarrc_set_pid(void* controller, int32_t kp_pm, int32_t ki_pm, int32_t kd_pm, int32_t ff_pm) {
  as<IarrcController>(controller)->pid().set_gains(PidGains{kp_pm, ki_pm, kd_pm, ff_pm});
}
void roar_iarrc_sbus_byte(void* controller, uint8_t byte, uint64_t now_us) {
  as<IarrcController>(controller)->sbus_byte(byte, now_us);
}
uint8_t roar_iarrc_host_byte(void* controller, uint8_t byte, uint64_t now_us) {
  return static_cast<uint8_t>(as<IarrcController>(controller)->host_byte(byte, now_us));
}
void roar_iarrc_encoder(void* controller, int32_t count, uint64_t now_us) {
  as<IarrcController>(controller)->encoder(count, now_us);
}
void roar_iarrc_battery(void* controller, uint16_t adc_counts) { as<IarrcController>(controller)->battery(adc_counts); }
void roar_iarrc_control(void* controller, uint64_t now_us, uint32_t frames_started, roar_iarrc_status_t* out) {
  IarrcController* c = as<IarrcController>(controller);
  iarrc_status(*c, c->control(now_us, frames_started), now_us, out);
}

uint8_t roar_iarrc_task_count(void) { return kIarrcTaskCount; }
void roar_iarrc_task(uint8_t index, roar_task_spec_t* out) {
  const TaskSpec& t = kIarrcTasks[index < kIarrcTaskCount ? index : 0];
  *out = roar_task_spec_t{t.name, t.period_us, t.priority, 0, t.stack_words, t.cost_us};
}
size_t roar_iarrc_board_size(void) { return sizeof(HostIarrcBoard); }
void roar_iarrc_board_init(void* board, roar_iarrc_hal_t* hal, uint32_t counts_per_m) {
  IarrcConfig config;
  if (counts_per_m > 0) config.counts_per_m = counts_per_m;
  new (board) HostIarrcBoard(hal, config);
}
void roar_iarrc_board_begin(void* board) {
  as<HostIarrcBoard>(board)->hal.begin();
  as<HostIarrcBoard>(board)->board.begin();
}
uint32_t roar_iarrc_board_session(const void* board) {
  return static_cast<const HostIarrcBoard*>(board)->board.controller().keys().auth().session();
}
void roar_iarrc_board_run(void* board, uint8_t task) {
  if (task < kIarrcTaskCount) as<HostIarrcBoard>(board)->board.run(static_cast<IarrcTask>(task));
}
void roar_iarrc_board_overran(void* board, uint8_t task, uint32_t missed) {
  if (task < kIarrcTaskCount) as<HostIarrcBoard>(board)->board.overran(static_cast<IarrcTask>(task), missed);
}
void roar_iarrc_board_set_pid(void* board, int32_t kp_pm, int32_t ki_pm, int32_t kd_pm, int32_t ff_pm) {
  as<HostIarrcBoard>(board)->board.controller().pid().set_gains(PidGains{kp_pm, ki_pm, kd_pm, ff_pm});
}
void roar_iarrc_board_status(const void* board, roar_iarrc_status_t* out) {
  const IarrcBoard& b = as<HostIarrcBoard>(board)->board;
  iarrc_status(b.controller(), b.outputs(), b.time(), out);
}
uint32_t roar_iarrc_board_overruns(const void* board) { return as<HostIarrcBoard>(board)->board.overruns(); }

}  // extern "C"
