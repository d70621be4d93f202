// AnyFC F7 (STM32F745) car skeleton: the same roar::CarBoard as every other board, behind a
// register-level HAL: 50 Hz pulses from TIM2/TIM5 PWM at 1 us per tick, USART1 at 115200 baud,
// time from the DWT cycle counter. It runs from the 16 MHz internal oscillator the chip starts
// on. The FreeRTOS controller (tasks, RC capture, USB serial) is a later issue; its task bodies
// will be this loop's pieces.
#include <stddef.h>
#include <stdint.h>

#include "pins.h"
#include "registers.h"
#include "roar/board.h"
#include "roar/protocol.h"

namespace {

constexpr uint32_t kCoreHz = 16000000;  // [Hz] HSI after reset
constexpr uint32_t kCyclesPerUs = kCoreHz / 1000000;

void enable_clocks() {
  reg::at(reg::kRcc + reg::kAhb1Enr) |= (1u << 0) | (1u << 1);  // GPIOA, GPIOB
  reg::at(reg::kRcc + reg::kApb1Enr) |= (1u << 0) | (1u << 3);  // TIM2, TIM5
  reg::at(reg::kRcc + reg::kApb2Enr) |= (1u << 4);              // USART1
  reg::at(reg::kDemcr) |= 1u << 24;                             // trace on: DWT cycle counter
  reg::at(reg::kDwt) |= 1u;
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

void start_pwm(uint32_t timer, uint32_t ccmr, uint32_t ccmr_shift, uint32_t ccer_bit) {
  reg::at(timer + reg::kPsc) = kCyclesPerUs - 1;                     // 1 us per tick
  reg::at(timer + reg::kArr) = roar::proto::kTimingServoFrameUs - 1;  // 20 ms frame
  reg::at(timer + ccmr) |= (6u << (ccmr_shift + 4)) | (1u << (ccmr_shift + 3));  // PWM mode 1, preload
  reg::at(timer + reg::kCcer) |= 1u << ccer_bit;
  reg::at(timer + reg::kEgr) = 1;   // load the registers
  reg::at(timer + reg::kCr1) = (1u << 7) | 1u;  // auto-reload preload, counter on
}

class Stm32Hal : public roar::Hal {
 public:
  void begin() {
    enable_clocks();
    configure(pins::kThrottleOut, 2);
    configure(pins::kSteeringOut, 2);
    configure(pins::kSerialTx, 2);
    configure(pins::kSerialRx, 2);
    configure(pins::kStatusLed, 1);
    start_pwm(reg::kTim2, reg::kCcmr2, 8, 12);  // CH4
    start_pwm(reg::kTim5, reg::kCcmr1, 8, 4);   // CH2
    write_pulses(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
    reg::at(reg::kUsart1 + reg::kUsartBrr) = (kCoreHz + roar::proto::kSerialBaud / 2) / roar::proto::kSerialBaud;
    reg::at(reg::kUsart1 + reg::kUsartCr1) = (1u << 3) | (1u << 2) | 1u;  // TX, RX, enable
  }

  roar::Micros now_us() override {  // extend the 32-bit cycle counter, then whole microseconds
    const uint32_t c = reg::at(reg::kDwt + 4);
    cycles_ += static_cast<uint32_t>(c - last_cycles_);
    last_cycles_ = c;
    return static_cast<roar::Micros>(cycles_ / kCyclesPerUs);
  }
  // Preloaded compare registers: the new width starts with the next frame.
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override {
    reg::at(reg::kTim2 + reg::kCcr4) = throttle_us;
    reg::at(reg::kTim5 + reg::kCcr2) = steering_us;
  }
  uint32_t frames_started() override {  // count update events (frame starts) as they happen
    if (reg::at(reg::kTim2 + reg::kSr) & 1u) {
      reg::at(reg::kTim2 + reg::kSr) = ~1u;
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
  void drain_serial() {  // one byte per call when the transmitter is free
    if (tx_count_ && (reg::at(reg::kUsart1 + reg::kUsartIsr) & reg::kIsrTxe)) {
      reg::at(reg::kUsart1 + reg::kUsartTdr) = static_cast<uint8_t>(tx_[tx_head_]);
      tx_head_ = (tx_head_ + 1) % sizeof(tx_);
      --tx_count_;
    }
  }

 private:
  uint64_t cycles_ = 0;
  uint32_t last_cycles_ = 0;
  uint32_t frames_ = 1;
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
