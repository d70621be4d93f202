// Emulator benchmark image (QEMU netduinoplus2, Cortex-M4, -icount): the cost of each IARRC task
// body (roar::IarrcBoard::run) at its worst input -- 64 SBUS bytes of good frames for the RC task,
// 64 bytes of setpoints for the host task, a PID command and a telemetry line for the telemetry
// task -- timed with SysTick beside the two-instruction calibration loop of sbus_bench.cpp.
// Reports "calibration_ticks N" and "task <name> <worst ticks of kRuns runs>"; exit status 0.
#include <stddef.h>
#include <stdint.h>

#include "semihosting.h"

#include "roar/iarrc_board.h"

namespace {

constexpr uint32_t kCalibration = 100000;  // iterations of the two-instruction loop
constexpr uint8_t kRuns = 20;

volatile uint32_t* const kSysTick = reinterpret_cast<volatile uint32_t*>(0xE000E010);  // CTRL, LOAD, VAL
constexpr uint32_t kSysTickMask = 0xFFFFFF;
uint32_t ticks_since(uint32_t start) { return (start - kSysTick[2]) & kSysTickMask; }

class BenchHal : public roar::IarrcHal {
 public:
  roar::RawMicros now = 100000;
  uint8_t sbus[64];
  uint8_t sbus_len = 0, sbus_pos = 0;
  const char* host = "";
  const char* link = "";
  size_t written = 0;

  roar::RawMicros now_us() override { return now; }
  bool read_sbus(uint8_t* byte, roar::RawMicros* at_us) override {
    if (sbus_pos >= sbus_len) return false;
    *at_us = now - (sbus_len - sbus_pos) * 120u;
    *byte = sbus[sbus_pos++];
    return true;
  }
  int read_host() override { return *host ? static_cast<uint8_t>(*host++) : -1; }
  int read_link() override { return *link ? static_cast<uint8_t>(*link++) : -1; }
  void write_host(const char*, size_t n) override { written += n; }
  void write_link(const char*, size_t n) override { written += n; }
  int32_t encoder_count() override { return static_cast<int32_t>(now / 10); }
  uint16_t battery_adc() override { return 1354; }
  int16_t gyro_z_raw() override { return 1234; }
  uint32_t frames_started() override { return now / 20000 + 1; }
  void write_pulses(uint16_t, uint16_t) override {}
  void feed_watchdog() override {}
  void lock() override {}
  void unlock() override {}
};

BenchHal hal;
roar::IarrcBoard board(hal);
uint8_t frames[3][roar::proto::kSbusFrameBytes];
const char kSetpoints[] = "[1500,1500][1500,1500][1500,1500][1500,1500][1500,1500][15";  // 64 bytes
const char kCommand[] = "PID 500 400 0 110\n";

void prepare(roar::IarrcTask task, uint8_t run) {
  hal.now += 2000;
  if (task == roar::IarrcTask::Rc) {  // the next 64 bytes of the frame stream
    for (uint8_t i = 0; i < sizeof(hal.sbus); ++i) {
      const uint32_t at = (run * sizeof(hal.sbus) + i) % (3 * roar::proto::kSbusFrameBytes);
      hal.sbus[i] = frames[at / roar::proto::kSbusFrameBytes][at % roar::proto::kSbusFrameBytes];
    }
    hal.sbus_len = sizeof(hal.sbus);
    hal.sbus_pos = 0;
  }
  if (task == roar::IarrcTask::Host) hal.host = kSetpoints;
  if (task == roar::IarrcTask::Telemetry) hal.link = kCommand;
}

}  // namespace

int main() {
  roar::SbusFrame frame = {};
  for (uint8_t f = 0; f < 3; ++f) {
    for (uint8_t c = 0; c < roar::kSbusChannels; ++c) frame.raw[c] = static_cast<uint16_t>(992 + 40 * f);
    frame.raw[4] = 1811;  // mode switch at autonomous
    roar::sbus_encode(frame, frames[f]);
  }
  kSysTick[1] = kSysTickMask;
  kSysTick[2] = 0;
  kSysTick[0] = 5;  // processor clock, no interrupt
  uint32_t start = kSysTick[2];
  for (uint32_t n = kCalibration; n; --n) __asm__ volatile("" ::: "memory");
  semihosting::say_number("calibration_ticks ", ticks_since(start));
  board.begin();
  for (uint8_t t = 0; t < roar::kIarrcTaskCount; ++t) {
    uint32_t worst = 0;
    for (uint8_t run = 0; run < kRuns; ++run) {
      const auto task = static_cast<roar::IarrcTask>(t);
      prepare(task, run);
      start = kSysTick[2];
      board.run(task);
      const uint32_t ticks = ticks_since(start);
      if (ticks > worst) worst = ticks;
    }
    char label[24] = "task ";
    uint8_t i = 5;
    for (const char* c = roar::kIarrcTasks[t].name; *c; ++c) label[i++] = *c;
    label[i++] = ' ';
    label[i] = '\0';
    semihosting::say_number(label, worst);
  }
  semihosting::leave(hal.written > 0 ? 0 : 1);
}
