// The ROAR GATT layout (PROTOCOL.md section 4) with ArduinoBLE:
//   control   write / write without response: control messages into the board's parser
//   velocity  read: float32 m/s; 0 (this board has no speedometer)
//   pid       write: 3 x float32 kp, kd, ki; kept for a speed controller, unused so far
//   state     read: float32 speed (0), float32 throttle output [us]
//   name      write: the name advertised from the next advertisement on (not persisted)
//   override  write: accepted; this board has no override output
//   session   read: uint32 session, uint32 last counter accepted (signed control; 0, 0 without a key)
#include "ble_link.h"

#if defined(ARDUINO_ARCH_MBED)
#include <ArduinoBLE.h>
#include <string.h>

#include "roar/protocol.h"

namespace {
constexpr int kMaxWrite = 20;          // [bytes] a name; control writes come in pieces of at most this on
                                       // a link without an MTU exchange
constexpr int kMaxControlWrite = roar::proto::kSignedMaxMessageBytes + 2;  // [bytes] a signed message and line end
constexpr unsigned long kStatePeriodMs = 100;  // [ms] state characteristic refresh
BLEService service(roar::proto::kBleServiceUuid);
BLECharacteristic control(roar::proto::kBleControlUuid, BLERead | BLEWrite | BLEWriteWithoutResponse, kMaxControlWrite);
BLECharacteristic session(roar::proto::kBleSessionUuid, BLERead, 2 * sizeof(uint32_t), true);
BLEFloatCharacteristic velocity(roar::proto::kBleVelocityUuid, BLERead);
BLECharacteristic pid(roar::proto::kBlePidUuid, BLEWrite, 3 * sizeof(float), true);
BLECharacteristic state(roar::proto::kBleStateUuid, BLERead, 2 * sizeof(float), true);
BLECharacteristic name(roar::proto::kBleNameUuid, BLEWrite, kMaxWrite);
BLEByteCharacteristic override_toggle(roar::proto::kBleOverrideUuid, BLEWrite);
float pid_gains[3] = {0, 0, 0};  // kp, kd, ki
char local_name[kMaxWrite + 1];
unsigned long last_state_ms = 0;
bool started = false;
}  // namespace

namespace ble_link {

void begin() {
  if (!BLE.begin()) return;  // no radio: the car still works over USB serial
  BLE.setLocalName(roar::proto::kBleLocalName);
  BLE.setAdvertisedService(service);
  for (BLECharacteristic* c : {&control, static_cast<BLECharacteristic*>(&velocity), &pid, &state, &name,
                               static_cast<BLECharacteristic*>(&override_toggle), &session}) {
    service.addCharacteristic(*c);
  }
  BLE.addService(service);
  velocity.writeValue(0.0f);
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
  if (pid.written() && pid.valueLength() == static_cast<int>(sizeof(pid_gains))) {
    memcpy(pid_gains, pid.value(), sizeof(pid_gains));  // little-endian float32, as the host packs them
  }
  if (name.written()) {
    int n = name.valueLength();
    if (n > kMaxWrite) n = kMaxWrite;
    memcpy(local_name, name.value(), static_cast<size_t>(n));
    local_name[n] = '\0';
    BLE.setLocalName(local_name);
  }
}

void publish(const roar::CarBoard& board, const roar::CarOutputs& outputs) {
  if (!started || millis() - last_state_ms < kStatePeriodMs) return;
  last_state_ms = millis();
  const float payload[2] = {0.0f, static_cast<float>(outputs.throttle_us)};
  state.writeValue(reinterpret_cast<const uint8_t*>(payload), sizeof(payload));
  const uint32_t signing[2] = {board.car().auth().session(), board.car().auth().last_counter()};  // little-endian
  session.writeValue(reinterpret_cast<const uint8_t*>(signing), sizeof(signing));
}

}  // namespace ble_link

#else

namespace ble_link {
void begin() {}
void poll(roar::CarBoard&) {}
void publish(const roar::CarBoard&, const roar::CarOutputs&) {}
}  // namespace ble_link

#endif
