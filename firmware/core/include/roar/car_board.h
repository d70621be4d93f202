// The board side of a servo/ESC car, shared by every board: a small HAL that each board folder
// implements (time, pulse outputs, a serial port, the hardware watchdog), and CarBoard, the
// loop body that moves bytes, time and pulses through the Car. Board glue stays a few dozen
// lines per board.
//
// The hardware watchdog is fed from one place only: the end of CarBoard::poll. A board whose
// loop hangs anywhere (in the core, in its BLE stack, in a driver) stops feeding it, resets
// within timing.loop_watchdog_us, and boots with its outputs at neutral, latched.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/car.h"

namespace roar {

class Hal {
 public:
  virtual RawMicros now_us() = 0;  // the free-running 32-bit microsecond counter (wraps)
  // New pulse widths for the ESC and the steering servo, taken at the start of the next frame.
  virtual void write_pulses(uint16_t throttle_us, uint16_t steering_us) = 0;
  virtual uint32_t frames_started() = 0;  // output frames begun since boot (wraps)
  virtual int read_byte() = 0;            // next received serial byte, or -1 when none
  virtual size_t write_room() = 0;        // bytes the serial port takes now without blocking
  virtual void write(const char* text, size_t length) = 0;
  virtual void feed_watchdog() = 0;       // the loop is alive: restart the hardware watchdog
  // Where the signing key and session counter live (roar/signing.h); nullptr: nowhere, so the
  // board can never be given a key.
  virtual Nvm* nvm() { return nullptr; }

 protected:
  ~Hal() = default;
};

class CarBoard {
 public:
  static const uint8_t kMaxBytesPerPoll = 64;  // keep the loop short under a byte flood

  CarBoard(Hal& hal, const CarConfig& config = CarConfig()) : hal_(hal), car_(config) {}

  // Call once the serial port is up: queues the boot banner (and the session, with a key).
  void begin() { car_.boot(hal_.nvm()); }

  // Bytes from another link (a BLE write), in order. They can drive, never set a key.
  void feed(const uint8_t* data, size_t length);

  // One RC receiver pulse measured by the board's input capture.
  void rc_pulse(RcChannel channel, uint16_t width_us) { car_.rc_pulse(channel, width_us, now()); }

  // The loop body: serial bytes in, one Car step, pulses out, reply lines out when they fit,
  // then the hardware watchdog fed.
  CarOutputs poll();

  const Car& car() const { return car_; }

 private:
  Micros now() { return clock_.extend(hal_.now_us()); }

  Hal& hal_;
  MonotonicClock clock_;
  Car car_;
};

}  // namespace roar
