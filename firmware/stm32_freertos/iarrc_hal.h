// The AnyFC F7's IarrcHal (iarrc_hal.cpp): the USARTs, encoder, battery, gyro, outputs and
// watchdog of the IARRC controller, behind the core's interface.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "key_flash.h"
#include "roar/flash_log.h"
#include "roar/iarrc_board.h"
#include "roar/spsc_bytes.h"
#include "rtos.h"

class AnyFcHal : public roar::IarrcHal {
 public:
#if ROAR_EMULATOR
  static constexpr uint32_t kCoreHz = 168000000;  // [Hz] QEMU's netduinoplus2 SYSCLK
#else
  static constexpr uint32_t kCoreHz = 16000000;  // [Hz] HSI after reset: the glue leaves the clock tree alone
#endif
  static constexpr uint16_t kTxBytes = 512;  // [bytes] per transmit ring

  void begin();  // the key's log first: it may erase a sector, before the watchdog starts

  roar::RawMicros now_us() override;
  bool read_sbus(uint8_t* byte, roar::RawMicros* at_us) override;
  int read_host() override;
  int read_link() override;
  void write_host(const char* text, size_t length) override;
  void write_link(const char* text, size_t length) override;
  int32_t encoder_count() override;
  uint16_t battery_adc() override;
  int16_t gyro_z_raw() override;
  uint32_t frames_started() override;
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override;
  void feed_watchdog() override;
  void lock() override;
  void unlock() override;
  roar::Nvm* nvm() override { return &key_log_; }

  // Filled by the USART interrupts, emptied by the tasks (and the other way round for tx).
  rtos::IsrBytes<256> host_rx, link_rx;
  rtos::IsrBytes<512> sbus_rx;  // 5-byte records: the byte, the 32-bit time it arrived
  roar::SpscBytes<kTxBytes> host_tx, link_tx;

 private:
  void queue(uint32_t base, roar::SpscBytes<kTxBytes>& tx, const char* text, size_t length);

  KeyFlash key_sectors_[2] = {KeyFlash(0), KeyFlash(1)};
  roar::FlashLog key_log_{key_sectors_[0], key_sectors_[1]};
  uint32_t frames_ = 0;
  int32_t encoder_ = 0;
  uint16_t encoder_raw_ = 0;
};
