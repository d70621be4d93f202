#include "ble_link.h"

#if defined(ARDUINO_ARCH_MBED)
#include <ArduinoBLE.h>

#include "roar/protocol.h"

namespace {
constexpr int kMaxWrite = 20;  // [bytes] one control message (11) with room for line ends
BLEService service(roar::proto::kBleServiceUuid);
BLECharacteristic control(roar::proto::kBleControlUuid, BLERead | BLEWrite | BLEWriteWithoutResponse, kMaxWrite);
bool started = false;
}  // namespace

namespace ble_link {

void begin() {
  if (!BLE.begin()) return;  // no radio: the car still works over USB serial
  BLE.setLocalName(roar::proto::kBleLocalName);
  BLE.setAdvertisedService(service);
  service.addCharacteristic(control);
  BLE.addService(service);
  BLE.advertise();
  started = true;
}

void poll(roar::CarBoard& board) {
  if (!started) return;
  BLE.poll();
  if (control.written()) {
    // Exactly the bytes written, however long: the parser rejects anything malformed.
    board.feed(control.value(), static_cast<size_t>(control.valueLength()));
  }
}

}  // namespace ble_link

#else

namespace ble_link {
void begin() {}
void poll(roar::CarBoard&) {}
}  // namespace ble_link

#endif
