#include "memory_boards.h"

#include "roar/text.h"

namespace roar {

roar_side_pins_t to_c(const SidePins& s) { return roar_side_pins_t{s.in1, s.in2, s.duty}; }

roar_car_outputs_t to_c(const CarOutputs& o, const Car& car) {
  return roar_car_outputs_t{o.throttle_us, o.steering_us, static_cast<uint8_t>(o.source),
                            static_cast<uint8_t>(o.brake_phase), static_cast<uint8_t>(car.latched() ? 1 : 0), 0};
}

// --- the ESC car -------------------------------------------------------------------------------

void CarMemoryHal::write_pulses(uint16_t throttle_us, uint16_t steering_us) {
  m_->pending_us[0] = throttle_us;
  m_->pending_us[1] = steering_us;
}

void CarMemoryHal::write(const char* text, size_t length) {
  for (size_t i = 0; i < length && m_->tx_len < sizeof(m_->tx); ++i) m_->tx[m_->tx_len++] = text[i];
}

void MemoryNvm::read(uint16_t at, uint8_t* data, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) data[i] = at + i < size_ ? bytes_[at + i] : 0xFF;
}

void MemoryNvm::write(uint16_t at, const uint8_t* data, uint8_t n) {
  for (uint8_t i = 0; i < n && at + i < size_; ++i) {
    if (bytes_[at + i] != data[i]) ++*writes_;  // as eeprom_update_block: only changed bytes
    bytes_[at + i] = data[i];
  }
}

bool MemoryFlash::program(uint32_t offset, const uint32_t* words, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) {
    if (m_->power_words == 0) return false;
    uint8_t* p = bytes_ + offset + 4u * i;
    if ((p[0] & p[1] & p[2] & p[3]) != 0xFF) {  // a word programmed twice: refused
      ++m_->double_programs;
      return false;
    }
    if (m_->power_words > 0) --m_->power_words;
    for (uint8_t b = 0; b < 4; ++b) p[b] &= static_cast<uint8_t>(words[i] >> (8 * b));
    ++m_->words_programmed;
  }
  return true;
}

bool MemoryFlash::erase() {
  if (m_->power_words == 0) return false;
  for (uint32_t i = 0; i < ROAR_FLASH_SECTOR_BYTES; ++i) bytes_[i] = 0xFF;
  ++m_->erases;
  return true;
}

HostCarBoard::HostCarBoard(roar_host_hal_t* m, const CarConfig& cfg) : hal(m), board(hal, cfg) {
  for (uint8_t ch = 0; ch < 2; ++ch) m->pending_us[ch] = m->wire_us[ch] = proto::kControlNeutralUs;  // as at boot
}

void HostCarBoard::run(uint32_t loops) {
  roar_host_hal_t* const mem = &hal.memory();
  for (uint32_t i = 0; i < loops; ++i) {
    const uint32_t late = mem->now_us - mem->next_frame_us;  // [us] past the due frame start
    if (static_cast<int32_t>(late) >= 0 && mem->frame_us > 0) {
      const uint32_t started = 1 + late / mem->frame_us;  // more than one if time jumped ahead
      mem->frames_started += started;
      mem->next_frame_us += started * mem->frame_us;
      mem->wire_us[0] = mem->pending_us[0];
      mem->wire_us[1] = mem->pending_us[1];
      for (uint8_t ch = 0; ch < 2; ++ch) {
        if (mem->rc_us[ch]) board.rc_pulse(static_cast<RcChannel>(ch), mem->rc_us[ch]);
      }
    }
    mem->outputs = to_c(board.poll(), board.car());
    mem->now_us += mem->loop_us;
  }
}

void serial_control(roar_host_hal_t* m, uint16_t throttle_us, uint16_t steering_us) {
  const uint16_t unread = m->rx_len > m->rx_pos ? m->rx_len - m->rx_pos : 0;
  for (uint16_t i = 0; i < unread; ++i) m->rx[i] = m->rx[m->rx_pos + i];
  char text[16];
  size_t length = 0;
  const char start[2] = {proto::kControlStartChar, 0}, separator[2] = {proto::kControlSeparatorChar, 0};
  const char end[2] = {proto::kControlEndChar, 0};
  append(text, sizeof(text), &length, start);
  append_uint(text, sizeof(text), &length, throttle_us);
  append(text, sizeof(text), &length, separator);
  append_uint(text, sizeof(text), &length, steering_us);
  append(text, sizeof(text), &length, end);
  uint16_t len = unread;
  for (size_t i = 0; i < length && len < sizeof(m->rx); ++i) m->rx[len++] = static_cast<uint8_t>(text[i]);
  m->rx_pos = 0;
  m->rx_len = len;
}

// --- the ROAR Junior ---------------------------------------------------------------------------

void JuniorMemoryHal::write_motors(const DrivePins& pins) {
  m_->left = to_c(pins.left);
  m_->right = to_c(pins.right);
}

void JuniorMemoryHal::write(const char* text, size_t length) {
  for (size_t i = 0; i < length && m_->tx_len < sizeof(m_->tx); ++i) m_->tx[m_->tx_len++] = text[i];
}

void HostJuniorBoard::run(uint32_t loops) {
  for (uint32_t i = 0; i < loops; ++i) {
    board.poll();
    hal.memory().now_us += hal.memory().loop_us;
  }
}

// --- the IARRC car -----------------------------------------------------------------------------

namespace {
void append_to(char* buf, uint16_t* len, const char* text, size_t n) {
  if (*len + n > ROAR_IARRC_TX_BYTES) return;  // a full UART drops the line
  for (size_t i = 0; i < n; ++i) buf[(*len)++] = text[i];
}
}  // namespace

bool IarrcMemoryHal::read_sbus(uint8_t* byte, RawMicros* at_us) {
  if (m_->sbus_pos >= m_->sbus_len) return false;
  *at_us = m_->sbus_at_us[m_->sbus_pos];
  *byte = m_->sbus[m_->sbus_pos++];
  return true;
}

void IarrcMemoryHal::write_host(const char* text, size_t n) { append_to(m_->host_tx, &m_->host_tx_len, text, n); }
void IarrcMemoryHal::write_link(const char* text, size_t n) { append_to(m_->link_tx, &m_->link_tx_len, text, n); }

void IarrcMemoryHal::write_pulses(uint16_t throttle_us, uint16_t steering_us) {
  m_->throttle_us = throttle_us;
  m_->steering_us = steering_us;
}

}  // namespace roar
