// The IARRC car's tasks, the same on the board (FreeRTOS), on the emulated Cortex-M4 (SysTick)
// and in the simulator (the host scheduler): one task table, and one body per task here. The
// board glue creates one RTOS task per row and calls run() every period; it keeps nothing else.
//
//   task       period  priority  does
//   rc          2 ms      5      SBUS bytes -> decoder (a person can take over or stop at once)
//   control    10 ms      4      encoder -> speed, mode state machine, PID -> pulses; watchdog
//   host        5 ms      3      setpoint bytes from the vision computer; ERR replies
//   gyro        5 ms      2      MPU6000 yaw rate (SPI)              } equal priorities share
//   telemetry 100 ms      2      TEL lines out, PID commands in       } the CPU round-robin
//   battery   500 ms      1      ADC -> volts, low warning, cutoff
//
// Tasks pre-empt each other, so every body touches the controller only inside the HAL's lock
// (a FreeRTOS mutex with priority inheritance on the board). A task that overruns its period
// runs again at once and then keeps its period from there; the releases it missed are counted
// (overruns, in telemetry). The hardware watchdog is fed by the control task, and only while the
// RC task also keeps running.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/clock.h"
#include "roar/iarrc.h"

namespace roar {

enum class IarrcTask : uint8_t { Rc = 0, Control = 1, Host = 2, Gyro = 3, Telemetry = 4, Battery = 5 };
static const uint8_t kIarrcTaskCount = 6;

struct TaskSpec {
  const char* name;
  DurationUs period_us;  // [us] release period (FreeRTOS: vTaskDelayUntil)
  uint8_t priority;      // higher pre-empts lower (FreeRTOS numbering; the idle task is 0)
  uint16_t stack_words;  // [32-bit words] stack depth given to xTaskCreate
  DurationUs cost_us;    // [us] declared worst-case execution time on the STM32F745 at 16 MHz
};

extern const TaskSpec kIarrcTasks[kIarrcTaskCount];

class IarrcHal {
 public:
  virtual RawMicros now_us() = 0;  // the free-running 32-bit microsecond counter (wraps)
  // The next received SBUS byte and the counter when it arrived (the USART interrupt stamps it),
  // or false when none is waiting.
  virtual bool read_sbus(uint8_t* byte, RawMicros* at_us) = 0;
  virtual int read_host() = 0;  // next byte from the vision computer's serial port, or -1
  virtual int read_link() = 0;  // next byte from the Bluetooth serial module, or -1
  virtual void write_host(const char* text, size_t length) = 0;  // dropped when it does not fit
  virtual void write_link(const char* text, size_t length) = 0;
  virtual int32_t encoder_count() = 0;    // the wheel encoder's timer count (x4, signed)
  virtual uint16_t battery_adc() = 0;     // [ADC counts] battery divider
  virtual int16_t gyro_z_raw() = 0;       // MPU6000 GYRO_ZOUT at +-2000 deg/s full scale
  virtual uint32_t frames_started() = 0;  // output frames begun since boot (wraps)
  virtual void write_pulses(uint16_t throttle_us, uint16_t steering_us) = 0;
  virtual void feed_watchdog() = 0;
  virtual void lock() = 0;  // the controller is shared by pre-empting tasks
  virtual void unlock() = 0;
  // Where the signing key and session live; nullptr: nowhere (the board takes no key).
  virtual Nvm* nvm() { return nullptr; }

 protected:
  ~IarrcHal() = default;
};

class IarrcBoard {
 public:
  static const uint8_t kMaxBytesPerRun = 64;  // [bytes] per task run: a byte flood cannot starve the rest

  IarrcBoard(IarrcHal& hal, const IarrcConfig& config = IarrcConfig()) : hal_(hal), controller_(config) {}

  // Call once the serial ports are up: READY 2 on the host port (and SESSION, with a key). KEY
  // lines are taken on the host port only, never from the Bluetooth link module.
  void begin();
  // One release of a task: its whole body, then back to the scheduler.
  void run(IarrcTask task);
  // The scheduler saw `missed` releases of a task pass while it was still running.
  void overran(IarrcTask task, uint32_t missed);

  const IarrcController& controller() const { return controller_; }
  IarrcController& controller() { return controller_; }
  const IarrcOutputs& outputs() const { return outputs_; }
  uint32_t overruns() const { return overruns_; }
  int32_t yaw_rate_mdeg_s() const { return yaw_rate_mdeg_s_; }
  Micros time() const { return clock_.now(); }  // as of the latest task run
  // The telemetry line (without line end) as the telemetry task would send it now.
  size_t telemetry_line(char* out, size_t cap) const;

 private:
  Micros now() { return clock_.extend(hal_.now_us()); }
  void run_rc();
  void run_control();
  void run_host();
  void run_gyro();
  void run_telemetry();
  void run_battery();
  void link_command();
  void write_both(const char* text, size_t length);

  IarrcHal& hal_;
  MonotonicClock clock_;
  IarrcController controller_;
  IarrcOutputs outputs_ = {proto::kControlNeutralUs, proto::kControlNeutralUs, IarrcMode::Boot, IarrcFailsafe::None};
  uint32_t overruns_ = 0;
  uint32_t rc_runs_ = 0, rc_runs_at_feed_ = 0;
  int32_t yaw_rate_mdeg_s_ = 0;
  void host_key_line(KeyLine::Event ev);
  KeyLine key_line_;
  char command_[proto::kTelemetryMaxLineBytes] = {};
  uint8_t command_len_ = 0;
  bool command_overflow_ = false;
};

}  // namespace roar
