// AnyFC F7 (STM32F745) car skeleton: the same roar::CarBoard as every other board, behind a
// register-level HAL: 50 Hz pulses from TIM5 PWM at 1 us per tick (S1_OUT on channel 4, S2_OUT on
// channel 2), frames counted from TIM5's update events, USART1 at 115200 baud, time from
// clock_source (the DWT cycle counter, or TIM2), and the independent watchdog. It runs from the
// 16 MHz internal oscillator the chip starts on. The FreeRTOS controller (tasks, RC capture, USB
// serial) is a later issue; its task bodies will be this loop's pieces.
#include <stddef.h>
#include <stdint.h>

#include "clock_source.h"
#include "pins.h"
#include "registers.h"
#include "roar/board.h"
#include "roar/protocol.h"

namespace {

constexpr uint32_t kCoreHz = 16000000;  // [Hz] HSI after reset
constexpr uint32_t kCyclesPerUs = kCoreHz / 1000000;
constexpr uint32_t kLsiHz = 32000;        // [Hz] the watchdog's oscillator (nominal)
constexpr uint32_t kIwdgPrescaler = 32;   // PR = 3: LSI / 32 -> 1 kHz
constexpr uint32_t kIwdgReload = static_cast<uint32_t>(
    static_cast<uint64_t>(roar::proto::kTimingLoopWatchdogUs) * (kLsiHz / kIwdgPrescaler) / 1000000);  // [ticks]
static_assert(kIwdgReload > 0 && kIwdgReload <= 0xFFF, "IWDG reload is 12 bits");

void enable_clocks() {
  reg::at(reg::kRcc + reg::kAhb1Enr) |= (1u << 0) | (1u << 1);  // GPIOA, GPIOB
  reg::at(reg::kRcc + reg::kApb1Enr) |= reg::kApb1Tim5;
  reg::at(reg::kRcc + reg::kApb2Enr) |= (1u << 4);              // USART1
}

void configure(const pins::Pin& pin, uint32_t mode) {  // mode: 0 input, 1 output, 2 alternate
  const uint32_t base = reg::gpio_base(pin.port);
  reg::at(base + reg::kModer) = (reg::at(base + reg::kModer) & ~(3u << (2 * pin.number))) | (mode << (2 * pin.number));
  if (mode == 2) {
    const uint32_t afr = pin.number < 8 ? reg::kAfrl : reg::kAfrh;
    const uint32_t shift = 4 * (pin.number % 8);
    reg::at(base + afr) = (reg::at(base + afr) & ~(0xFu << shift)) | (uint32_t{pin.alternate} << shift);
  }
}

void start_frames() {  // TIM5: 1 us per tick, 20 ms frames, PWM mode 1 with preload on CH2 and CH4
  reg::at(reg::kTim5 + reg::kPsc) = kCyclesPerUs - 1;
  reg::at(reg::kTim5 + reg::kArr) = roar::proto::kTimingServoFrameUs - 1;
  reg::at(reg::kTim5 + reg::kCcmr1) |= (6u << 12) | (1u << 11);  // CH2
  reg::at(reg::kTim5 + reg::kCcmr2) |= (6u << 12) | (1u << 11);  // CH4
  reg::at(reg::kTim5 + reg::kCcer) |= (1u << 4) | (1u << 12);   // CH2, CH4 outputs on
  reg::at(reg::kTim5 + reg::kEgr) = 1;                          // load the registers
  reg::at(reg::kTim5 + reg::kSr) = 0;
  reg::at(reg::kTim5 + reg::kCr1) = (1u << 7) | 1u;             // auto-reload preload, counter on
}

void start_watchdog() {
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgStart;  // also starts the LSI
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgUnlock;
  reg::at(reg::kIwdg + reg::kIwdgPr) = 3;
  reg::at(reg::kIwdg + reg::kIwdgRlr) = kIwdgReload;
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgFeed;
}

class Stm32Hal : public roar::Hal {
 public:
  void begin() {
    enable_clocks();
    clock_source::begin(kCoreHz);
    configure(pins::kThrottleOut, 2);
    configure(pins::kSteeringOut, 2);
    configure(pins::kSerialTx, 2);
    configure(pins::kSerialRx, 2);
    configure(pins::kStatusLed, 1);
    write_pulses(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
    start_frames();
    reg::at(reg::kUsart1 + reg::kUsartBrr) = (kCoreHz + roar::proto::kSerialBaud / 2) / roar::proto::kSerialBaud;
    reg::at(reg::kUsart1 + reg::kUsartCr1) = (1u << 3) | (1u << 2) | 1u;  // TX, RX, enable
    start_watchdog();
  }

  roar::RawMicros now_us() override { return clock_source::now_us(); }
  // Preloaded compare registers: the new width starts with the next frame.
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override {
    reg::at(reg::kTim5 + reg::kCcr4) = throttle_us;
    reg::at(reg::kTim5 + reg::kCcr2) = steering_us;
  }
  // A set update flag means at least one frame started since the last call: the count may run
  // behind after a stall, but it advances only when a frame really started, which is what the
  // brake sequence needs.
  uint32_t frames_started() override {
    if (reg::at(reg::kTim5 + reg::kSr) & 1u) {
      reg::at(reg::kTim5 + reg::kSr) = ~1u;
      ++frames_;
    }
    return frames_;
  }
  int read_byte() override {
    return (reg::at(reg::kUsart1 + reg::kUsartIsr) & reg::kIsrRxne) ? static_cast<int>(reg::at(reg::kUsart1 + reg::kUsartRdr) & 0xFF)
                                                                      : -1;
  }
  size_t write_room() override { return sizeof(tx_) - tx_count_; }
  void write(const char* text, size_t length) override {
    for (size_t i = 0; i < length && tx_count_ < sizeof(tx_); ++i) {
      tx_[(tx_head_ + tx_count_++) % sizeof(tx_)] = text[i];
    }
  }
  void feed_watchdog() override { reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgFeed; }
  void drain_serial() {  // one byte per call when the transmitter is free
    if (tx_count_ && (reg::at(reg::kUsart1 + reg::kUsartIsr) & reg::kIsrTxe)) {
      reg::at(reg::kUsart1 + reg::kUsartTdr) = static_cast<uint8_t>(tx_[tx_head_]);
      tx_head_ = (tx_head_ + 1) % sizeof(tx_);
      --tx_count_;
    }
  }

 private:
  uint32_t frames_ = 0;
  char tx_[128];
  size_t tx_head_ = 0, tx_count_ = 0;
};

Stm32Hal hal;
roar::CarBoard board(hal);

}  // namespace

int main() {
  hal.begin();
  board.begin();
  for (;;) {
    const roar::CarOutputs out = board.poll();
    hal.drain_serial();
    const uint32_t led = reg::gpio_base(pins::kStatusLed.port) + reg::kOdr;
    reg::at(led) = out.source == roar::ControlSource::Host ? (reg::at(led) | (1u << pins::kStatusLed.number))
                                                           : (reg::at(led) & ~(1u << pins::kStatusLed.number));
  }
}
