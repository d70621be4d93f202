// The AnyFC F7's IarrcHal, register level: three USARTs fed by their interrupts (the vision
// computer, the Bluetooth module, the SBUS receiver, whose bytes are stamped on arrival), the
// wheel encoder on TIM3 in encoder mode, the battery on ADC1, the MPU6000's yaw rate over SPI1,
// 50 Hz pulses from TIM5 with frames counted from its update events, and the IWDG. Replies go
// out from transmit rings that the USART interrupts drain.
//
// In the emulator build (ROAR_EMULATOR, QEMU's netduinoplus2) the USARTs are the same code; the
// encoder, battery and gyro read fixed stand-ins (QEMU models none of them) and time comes from
// SysTick (QEMU models it exactly), so the outputs are reported in the telemetry lines.
#include "iarrc_hal.h"

#include "clock_source.h"
#include "pins.h"
#include "registers.h"

namespace {

constexpr uint32_t kLsiHz = 32000;       // [Hz] the watchdog's oscillator (nominal)
constexpr uint32_t kIwdgPrescaler = 32;  // PR = 3: LSI / 32 -> 1 kHz
constexpr uint32_t kIwdgReload = static_cast<uint32_t>(
    static_cast<uint64_t>(roar::proto::kTimingLoopWatchdogUs) * (kLsiHz / kIwdgPrescaler) / 1000000);  // [ticks]
static_assert(kIwdgReload > 0 && kIwdgReload <= 0xFFF, "IWDG reload is 12 bits");
constexpr uint32_t kUsartIrqPriority = 6u << 4;  // below FreeRTOS's syscall ceiling (5 << 4)
constexpr uint8_t kMpuGyroZHigh = 0x47, kSpiRead = 0x80;
constexpr uint32_t kSpiSpins = 1000;  // [polls] give up on a silent gyro

AnyFcHal* hal = nullptr;

void configure(const pins::Pin& pin, uint32_t mode) {  // mode: 0 input, 1 output, 2 alternate, 3 analog
  const uint32_t base = reg::gpio_base(pin.port);
  reg::at(base + reg::kModer) = (reg::at(base + reg::kModer) & ~(3u << (2 * pin.number))) | (mode << (2 * pin.number));
  if (mode == 2) {
    const uint32_t afr = pin.number < 8 ? reg::kAfrl : reg::kAfrh;
    const uint32_t shift = 4 * (pin.number % 8);
    reg::at(base + afr) = (reg::at(base + afr) & ~(0xFu << shift)) | (uint32_t{pin.alternate} << shift);
  }
}

void set_pin(const pins::Pin& pin, bool high) {
  reg::at(reg::gpio_base(pin.port) + reg::kBsrr) = 1u << (pin.number + (high ? 0 : 16));
}

// 8N1 at `baud`, or SBUS: 8 data bits, even parity, 2 stop bits, inverted (F7 only; an F4 board
// has an inverter in front of the pin). Receive interrupt on.
void start_usart(uint32_t base, uint32_t irq, uint32_t baud, bool sbus) {
  reg::at(base + reg::kUsartBrr) = (AnyFcHal::kCoreHz + baud / 2) / baud;
  if (sbus) reg::at(base + reg::kUsartCr2) = reg::kUsartTwoStop | reg::kUsartRxInvert;
  reg::at(base + reg::kUsartCr1) = reg::kUsartEnable | reg::kUsartTe | reg::kUsartRe | reg::kUsartRxneie |
                                   (sbus ? reg::kUsartParity | reg::kUsartNineBits : 0u);
  reinterpret_cast<volatile uint8_t*>(reg::kNvicIpr)[irq] = kUsartIrqPriority;
  reg::at(reg::kNvicIser + 4 * (irq / 32)) = 1u << (irq % 32);
}

// The received byte, or -1; clears an overrun or framing error so that reception goes on.
int usart_byte(uint32_t base) {
  const uint32_t status = reg::at(base + reg::kUsartStatus);
#if !ROAR_STM32F4
  if (status & reg::kStatusErrors) reg::at(base + reg::kUsartClear) = reg::kStatusErrors;
#endif
  if (!(status & (reg::kStatusRxne | reg::kStatusErrors))) return -1;
  const int byte = static_cast<int>(reg::at(base + reg::kUsartRdr) & 0xFF);  // (on the F4 this read clears errors)
  return status & reg::kStatusRxne ? byte : -1;
}

template <uint16_t N>
void send_next(uint32_t base, roar::SpscBytes<N>& tx) {  // the transmit interrupt: one byte, or stop
  uint8_t byte;
  if (!(reg::at(base + reg::kUsartCr1) & reg::kUsartTxeie) || !(reg::at(base + reg::kUsartStatus) & reg::kStatusTxe)) return;
  if (tx.pop(&byte, 1)) {
    reg::at(base + reg::kUsartTdr) = byte;
  } else {
    reg::at(base + reg::kUsartCr1) &= ~reg::kUsartTxeie;
  }
}

}  // namespace

namespace {
// A serial port's interrupt: a received byte into its queue, the next byte out of its ring.
template <typename Rx, typename Tx>
void serve(uint32_t base, Rx& rx, Tx& tx) {
  const int byte = usart_byte(base);
  if (byte >= 0) {
    const uint8_t b = static_cast<uint8_t>(byte);
    rx.push_from_isr(&b, 1);
  }
  send_next(base, tx);
}
}  // namespace

extern "C" void USART1_IRQHandler() { serve(reg::kUsart1, hal->host_rx, hal->host_tx); }
extern "C" void USART3_IRQHandler() { serve(reg::kUsart3, hal->link_rx, hal->link_tx); }

extern "C" void USART6_IRQHandler() {
  const int byte = usart_byte(reg::kUsart6);
  if (byte < 0) return;
  const roar::RawMicros at = hal->now_us();
  const uint8_t record[5] = {static_cast<uint8_t>(byte), static_cast<uint8_t>(at), static_cast<uint8_t>(at >> 8),
                             static_cast<uint8_t>(at >> 16), static_cast<uint8_t>(at >> 24)};
  hal->sbus_rx.push_from_isr(record, sizeof(record));
}

void AnyFcHal::begin() {
  hal = this;
  key_log_.begin();
  host_rx.begin();
  link_rx.begin();
  sbus_rx.begin();
  reg::at(reg::kRcc + reg::kAhb1Enr) |= 7u;  // GPIOA, B, C
  reg::at(reg::kRcc + reg::kApb1Enr) |= reg::kApb1Tim3 | reg::kApb1Tim5 | reg::kApb1Usart3;
  reg::at(reg::kRcc + reg::kApb2Enr) |= reg::kApb2Usart1 | reg::kApb2Usart6 | reg::kApb2Adc1 | reg::kApb2Spi1;
#if !ROAR_EMULATOR
  clock_source::begin(kCoreHz);
#endif
  const pins::Pin alternate[] = {pins::kThrottleOut, pins::kSteeringOut, pins::kHostTx, pins::kHostRx,
                                  pins::kLinkTx, pins::kLinkRx, pins::kSbusRx, pins::kEncoderA, pins::kEncoderB,
                                  pins::kGyroSck, pins::kGyroMiso, pins::kGyroMosi};
  for (const pins::Pin& p : alternate) configure(p, 2);
  configure(pins::kGyroCs, 1);
  set_pin(pins::kGyroCs, true);
  configure(pins::kBattery, 3);
  configure(pins::kStatusLed, 1);
  // TIM5: 1 us per tick, 20 ms frames, PWM mode 1 with preload on CH2 and CH4
  write_pulses(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
  reg::at(reg::kTim5 + reg::kPsc) = kCoreHz / 1000000 - 1;
  reg::at(reg::kTim5 + reg::kArr) = roar::proto::kTimingServoFrameUs - 1;
  reg::at(reg::kTim5 + reg::kCcmr1) |= (6u << 12) | (1u << 11);
  reg::at(reg::kTim5 + reg::kCcmr2) |= (6u << 12) | (1u << 11);
  reg::at(reg::kTim5 + reg::kCcer) |= (1u << 4) | (1u << 12);
  reg::at(reg::kTim5 + reg::kEgr) = 1;
  reg::at(reg::kTim5 + reg::kSr) = 0;
  reg::at(reg::kTim5 + reg::kCr1) = (1u << 7) | 1u;
  // TIM3: encoder mode 3 (both edges of both channels: x4), counting over all 16 bits
  reg::at(reg::kTim3 + reg::kArr) = 0xFFFF;
  reg::at(reg::kTim3 + reg::kCcmr1) = (1u << 0) | (1u << 8);  // CC1 on TI1, CC2 on TI2
  reg::at(reg::kTim3 + reg::kSmcr) = 3u;
  reg::at(reg::kTim3 + reg::kCr1) = 1u;
  // ADC1 on, SPI1 master at core/16 with software chip select (mode 3, as the MPU6000 wants)
  reg::at(reg::kAdc1 + reg::kAdcCr2) = reg::kAdcOn;
  reg::at(reg::kAdc1 + reg::kAdcSqr3) = pins::kBatteryAdcChannel;
  reg::at(reg::kAdc1 + reg::kAdcSmpr1) = 7u << (3 * (pins::kBatteryAdcChannel - 10));  // 480 cycles: a divider
#if !ROAR_STM32F4
  reg::at(reg::kSpi1 + reg::kSpiCr2) = (7u << 8) | (1u << 12);  // 8-bit frames, RXNE at 8 bits
#endif
  reg::at(reg::kSpi1 + reg::kSpiCr1) = (1u << 9) | (1u << 8) | (1u << 6) | (3u << 3) | (1u << 2) | 3u;
  start_usart(reg::kUsart1, reg::kIrqUsart1, roar::proto::kSerialBaud, false);
  start_usart(reg::kUsart3, reg::kIrqUsart3, roar::proto::kSerialBaud, false);
  start_usart(reg::kUsart6, reg::kIrqUsart6, roar::proto::kSbusBaud, true);
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgStart;  // also starts the LSI
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgUnlock;
  reg::at(reg::kIwdg + reg::kIwdgPr) = 3;
  reg::at(reg::kIwdg + reg::kIwdgRlr) = kIwdgReload;
  reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgFeed;
}

roar::RawMicros AnyFcHal::now_us() {
#if ROAR_EMULATOR
  return rtos::systick_us();
#else
  return clock_source::now_us();
#endif
}

bool AnyFcHal::read_sbus(uint8_t* byte, roar::RawMicros* at_us) {
  uint8_t record[5];
  if (sbus_rx.pop(record, sizeof(record)) != sizeof(record)) return false;  // records go in whole
  *byte = record[0];
  *at_us = record[1] | (uint32_t{record[2]} << 8) | (uint32_t{record[3]} << 16) | (uint32_t{record[4]} << 24);
  return true;
}

int AnyFcHal::read_host() {
  uint8_t b;
  return host_rx.pop(&b, 1) ? b : -1;
}

int AnyFcHal::read_link() {
  uint8_t b;
  return link_rx.pop(&b, 1) ? b : -1;
}

void AnyFcHal::queue(uint32_t base, roar::SpscBytes<kTxBytes>& tx, const char* text, size_t length) {
  rtos::critical_enter();  // several tasks write; the interrupt reads
  tx.push(reinterpret_cast<const uint8_t*>(text), length);  // a line that does not fit is dropped whole
#if ROAR_EMULATOR
  // QEMU 7.2's USART raises no transmit interrupt, and its transmitter is never busy: send now.
  uint8_t byte;
  while (tx.pop(&byte, 1)) reg::at(base + reg::kUsartTdr) = byte;
#else
  reg::at(base + reg::kUsartCr1) |= reg::kUsartTxeie;
#endif
  rtos::critical_exit();
}

void AnyFcHal::write_host(const char* text, size_t length) { queue(reg::kUsart1, host_tx, text, length); }
void AnyFcHal::write_link(const char* text, size_t length) { queue(reg::kUsart3, link_tx, text, length); }

int32_t AnyFcHal::encoder_count() {
#if ROAR_EMULATOR
  return 0;  // the car stands still
#else
  const uint16_t raw = static_cast<uint16_t>(reg::at(reg::kTim3 + reg::kCnt));
  encoder_ += static_cast<int16_t>(raw - encoder_raw_);  // extended past the timer's 16 bits
  encoder_raw_ = raw;
  return encoder_;
#endif
}

uint16_t AnyFcHal::battery_adc() {
#if ROAR_EMULATOR
  return 1354;  // 12.0 V through the divider
#else
  reg::at(reg::kAdc1 + reg::kAdcCr2) |= reg::kAdcStart;
  for (uint32_t i = 0; i < kSpiSpins && !(reg::at(reg::kAdc1 + reg::kAdcSr) & reg::kAdcEoc); ++i) {
  }
  return static_cast<uint16_t>(reg::at(reg::kAdc1 + reg::kAdcDr) & 0xFFF);
#endif
}

int16_t AnyFcHal::gyro_z_raw() {
#if ROAR_EMULATOR
  return 0;
#else
  uint8_t in[3] = {};
  const uint8_t out[3] = {kMpuGyroZHigh | kSpiRead, 0, 0};
  set_pin(pins::kGyroCs, false);
  for (uint8_t i = 0; i < 3; ++i) {
    uint32_t spins = 0;
    while (!(reg::at(reg::kSpi1 + reg::kSpiSr) & reg::kSpiTxe) && ++spins < kSpiSpins) {
    }
    *reinterpret_cast<volatile uint8_t*>(reg::kSpi1 + reg::kSpiDr) = out[i];
    while (!(reg::at(reg::kSpi1 + reg::kSpiSr) & reg::kSpiRxne) && ++spins < kSpiSpins) {
    }
    in[i] = *reinterpret_cast<volatile uint8_t*>(reg::kSpi1 + reg::kSpiDr);
  }
  set_pin(pins::kGyroCs, true);
  return static_cast<int16_t>((in[1] << 8) | in[2]);
#endif
}

// A set update flag means at least one frame started since the last call: the count may run
// behind after a stall, but it advances only when a frame really started (the brake sequence's need).
uint32_t AnyFcHal::frames_started() {
#if ROAR_EMULATOR
  return rtos::systick_us() / roar::proto::kTimingServoFrameUs + 1;  // QEMU's timers raise no update flag
#else
  if (reg::at(reg::kTim5 + reg::kSr) & 1u) {
    reg::at(reg::kTim5 + reg::kSr) = ~1u;
    ++frames_;
  }
  return frames_;
#endif
}

// Preloaded compare registers: the new widths start with the next frame.
void AnyFcHal::write_pulses(uint16_t throttle_us, uint16_t steering_us) {
  reg::at(reg::kTim5 + reg::kCcr4) = throttle_us;
  reg::at(reg::kTim5 + reg::kCcr2) = steering_us;
}

void AnyFcHal::feed_watchdog() { reg::at(reg::kIwdg + reg::kIwdgKr) = reg::kIwdgFeed; }
void AnyFcHal::lock() { rtos::lock(); }
void AnyFcHal::unlock() { rtos::unlock(); }
