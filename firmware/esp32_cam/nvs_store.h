// The core's non-volatile memory (roar::Nvm: the signing key and session) on an ESP32, shared by
// the ESP32-CAM car and the ROAR Junior: one NVS blob (the Preferences library, namespace "roar"),
// read once at boot and written whole when it changes (a boot's new session, a key set over
// serial); NVS spreads the wear.
#pragma once
#include <Preferences.h>
#include <string.h>

#include "roar/signing.h"

namespace roar_esp32 {

class NvsStore : public roar::CachedNvm {
 public:
  void begin() {
    memset(cache(), 0xFF, kBytes);  // blank, as an erased EEPROM
    prefs_.begin("roar", false);
    prefs_.getBytes("signing", cache(), kBytes);
  }

 private:
  void persist(const uint8_t* data, uint8_t n) override { prefs_.putBytes("signing", data, n); }
  Preferences prefs_;
};

}  // namespace roar_esp32
