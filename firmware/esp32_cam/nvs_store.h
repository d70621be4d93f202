// The core's non-volatile memory (roar::Nvm: the signing key and session) on an ESP32, shared by
// the ESP32-CAM car and the ROAR Junior: one NVS blob (the Preferences library, namespace "roar"),
// read once at boot and written whole when it changes (a boot's new session, a key set over
// serial); NVS spreads the wear.
#pragma once
#include <Preferences.h>
#include <string.h>

#include "roar/signing.h"

namespace roar_esp32 {

class NvsStore : public roar::Nvm {
 public:
  void begin() {
    memset(bytes_, 0xFF, sizeof(bytes_));  // blank, as an erased EEPROM
    prefs_.begin("roar", false);
    prefs_.getBytes("signing", bytes_, sizeof(bytes_));
  }
  void read(uint16_t at, uint8_t* data, uint8_t n) override {
    for (uint8_t i = 0; i < n; ++i) data[i] = at + i < sizeof(bytes_) ? bytes_[at + i] : 0xFF;
  }
  void write(uint16_t at, const uint8_t* data, uint8_t n) override {
    for (uint8_t i = 0; i < n && at + i < sizeof(bytes_); ++i) bytes_[at + i] = data[i];
    prefs_.putBytes("signing", bytes_, sizeof(bytes_));
  }

 private:
  Preferences prefs_;
  uint8_t bytes_[roar::KeyRecord::kBytes];
};

}  // namespace roar_esp32
