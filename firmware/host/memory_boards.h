// The host "board": the core's three board loops on HALs of plain memory -- the structs of
// c_api.h, which the simulator fills and reads between calls -- a sibling of the real boards'
// glue in firmware/<board>/ (as ArduPilot keeps AP_HAL_SITL beside its board HALs). What a
// board's peripherals would do (its 32-bit microsecond counter, output frames, serial ports,
// the watchdog) is done here on that memory; every decision stays in the core.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "c_api.h"
#include "roar/car_board.h"
#include "roar/flash_log.h"
#include "roar/iarrc_board.h"
#include "roar/junior_board.h"

namespace roar {

roar_side_pins_t to_c(const SidePins& s);
roar_car_outputs_t to_c(const CarOutputs& o, const Car& car);

// A board's non-volatile memory as bytes of the caller's struct, counting the bytes that change
// (as eeprom_update_block writes only those).
class MemoryNvm : public Nvm {
 public:
  MemoryNvm(uint8_t* bytes, uint16_t size, uint16_t* writes) : bytes_(bytes), size_(size), writes_(writes) {}
  void read(uint16_t at, uint8_t* data, uint8_t n) override;
  void write(uint16_t at, const uint8_t* data, uint8_t n) override;

 private:
  uint8_t* bytes_;
  uint16_t size_;
  uint16_t* writes_;
};

// One of roar_flash_t's sectors: bits only cleared, erased whole, the power cut on request.
class MemoryFlash : public FlashSector {
 public:
  MemoryFlash(roar_flash_t* m, uint8_t sector) : m_(m), bytes_(m->bytes + sector * ROAR_FLASH_SECTOR_BYTES) {}
  uint32_t size() const override { return ROAR_FLASH_SECTOR_BYTES; }
  const uint8_t* bytes() const override { return bytes_; }
  bool program(uint32_t offset, const uint32_t* words, uint8_t n) override;
  bool erase() override;

 private:
  roar_flash_t* m_;
  uint8_t* bytes_;
};

// --- the ESC car: CarBoard on roar_host_hal_t ------------------------------------------------
class CarMemoryHal : public Hal {
 public:
  explicit CarMemoryHal(roar_host_hal_t* m) : m_(m), nvm_(m->nvm, sizeof(m->nvm), &m->nvm_writes) {}
  Nvm* nvm() override { return &nvm_; }
  roar_host_hal_t& memory() { return *m_; }
  RawMicros now_us() override { return m_->now_us; }
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override;
  uint32_t frames_started() override { return m_->frames_started; }
  int read_byte() override { return m_->rx_pos < m_->rx_len ? m_->rx[m_->rx_pos++] : -1; }
  size_t write_room() override { return sizeof(m_->tx) - m_->tx_len; }
  void write(const char* text, size_t length) override;
  void feed_watchdog() override { ++m_->watchdog_feeds; }

 private:
  roar_host_hal_t* m_;
  MemoryNvm nvm_;
};

// CarBoard with the output timer a board's hardware would run (roar_board_run in c_api.h).
struct HostCarBoard {
  HostCarBoard(roar_host_hal_t* m, const CarConfig& cfg);
  void run(uint32_t loops);

  CarMemoryHal hal;
  CarBoard board;
};

// A control message arriving on a board's serial port as a host writes it (roar.protocol's
// encode: start, throttle, separator, steering, end), after the bytes the loop has not read yet.
void serial_control(roar_host_hal_t* m, uint16_t throttle_us, uint16_t steering_us);

// --- the ROAR Junior: JuniorBoard on roar_junior_hal_t ----------------------------------------
class JuniorMemoryHal : public JuniorHal {
 public:
  explicit JuniorMemoryHal(roar_junior_hal_t* m) : m_(m), nvm_(m->nvm, sizeof(m->nvm), &m->nvm_writes) {}
  roar_junior_hal_t& memory() { return *m_; }
  RawMicros now_us() override { return m_->now_us; }
  void write_motors(const DrivePins& pins) override;
  void feed_watchdog() override { ++m_->watchdog_feeds; }
  int read_byte() override { return m_->rx_pos < m_->rx_len ? m_->rx[m_->rx_pos++] : -1; }
  void write(const char* text, size_t length) override;
  Nvm* nvm() override { return &nvm_; }

 private:
  roar_junior_hal_t* m_;
  MemoryNvm nvm_;
};

struct HostJuniorBoard {
  explicit HostJuniorBoard(roar_junior_hal_t* m) : hal(m), board(hal) {}
  void run(uint32_t loops);

  JuniorMemoryHal hal;
  JuniorBoard board;
};

// --- the IARRC car: IarrcBoard on roar_iarrc_hal_t --------------------------------------------
// The caller is the scheduler: it runs one task body at a time, so the lock has nothing to do.
class IarrcMemoryHal : public IarrcHal {
 public:
  explicit IarrcMemoryHal(roar_iarrc_hal_t* m) : m_(m), flash_{{&m->flash, 0}, {&m->flash, 1}}, log_(flash_[0], flash_[1]) {}
  void begin() { log_.begin(); }  // as the F7's glue does before its watchdog starts
  Nvm* nvm() override { return &log_; }
  RawMicros now_us() override { return m_->now_us; }
  bool read_sbus(uint8_t* byte, RawMicros* at_us) override;
  int read_host() override { return m_->host_pos < m_->host_len ? m_->host_rx[m_->host_pos++] : -1; }
  int read_link() override { return m_->link_pos < m_->link_len ? m_->link_rx[m_->link_pos++] : -1; }
  void write_host(const char* text, size_t n) override;
  void write_link(const char* text, size_t n) override;
  int32_t encoder_count() override { return m_->encoder_count; }
  uint16_t battery_adc() override { return m_->battery_adc; }
  int16_t gyro_z_raw() override { return m_->gyro_z_raw; }
  uint32_t frames_started() override { return m_->frames_started; }
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override;
  void feed_watchdog() override { ++m_->watchdog_feeds; }
  void lock() override {}
  void unlock() override {}

 private:
  roar_iarrc_hal_t* m_;
  MemoryFlash flash_[2];
  FlashLog log_;
};

struct HostIarrcBoard {
  HostIarrcBoard(roar_iarrc_hal_t* memory, const IarrcConfig& config) : hal(memory), board(hal, config) {}

  IarrcMemoryHal hal;
  IarrcBoard board;
};

}  // namespace roar
