// The car firmware for the ESP32-CAM: BLE (the ESP32 Arduino core's BLE library) and USB serial
// into roar::CarBoard; 50 Hz servo pulses from the LEDC peripheral on GPIO14 (ESC) and GPIO2
// (steering). Built with PlatformIO (env esp32cam; arduino-esp32 2.x LEDC API).
//
// The ROAR GATT layout (PROTOCOL.md section 4): control (write, write without response),
// velocity (read, 0: no speedometer here), pid (write, 3 x float32, kept), state (read: speed 0,
// throttle output [us] as float32), name (write: advertised from the next start of advertising,
// not persisted), override (write: accepted; this board has no override output).
#include <Arduino.h>
#include <BLEDevice.h>
#include <BLEServer.h>
#include <esp_gap_ble_api.h>
#include <string.h>

#include "pins.h"
#include "roar/board.h"
#include "roar/protocol.h"

namespace {

constexpr uint32_t kFrameHz = 1000000ul / roar::proto::kTimingServoFrameUs;  // [Hz] 50
constexpr uint8_t kLedcBits = 16;
constexpr uint32_t kLedcFullScale = (1ul << kLedcBits) - 1;

uint32_t duty_for(uint16_t pulse_us) {  // [LEDC counts] for a pulse in a 20 ms frame
  return static_cast<uint32_t>(pulse_us) * kLedcFullScale / roar::proto::kTimingServoFrameUs;
}

class Esp32Hal : public roar::Hal {
 public:
  void begin() {
    ledcSetup(pins::kThrottleChannel, kFrameHz, kLedcBits);
    ledcSetup(pins::kSteeringChannel, kFrameHz, kLedcBits);
    ledcAttachPin(pins::kThrottleOut, pins::kThrottleChannel);
    ledcAttachPin(pins::kSteeringOut, pins::kSteeringChannel);
    write_pulses(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
    started_us_ = micros();
  }
  roar::Micros now_us() override { return micros(); }
  // LEDC takes a new duty at the end of the current period, i.e. at the next frame start.
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override {
    ledcWrite(pins::kThrottleChannel, duty_for(throttle_us));
    ledcWrite(pins::kSteeringChannel, duty_for(steering_us));
  }
  uint32_t frames_started() override { return (micros() - started_us_) / roar::proto::kTimingServoFrameUs + 1; }
  int read_byte() override { return Serial.read(); }
  size_t write_room() override { return static_cast<size_t>(Serial.availableForWrite()); }
  void write(const char* text, size_t length) override { Serial.write(text, length); }

 private:
  uint32_t started_us_ = 0;
};

Esp32Hal hal;
roar::CarBoard board(hal);

// BLE writes arrive on the BLE task: hand them to the loop through a small lock-free ring.
constexpr size_t kRing = 256;
uint8_t ring[kRing];
volatile size_t ring_head = 0, ring_tail = 0;
volatile bool connected = false;

class ControlWrites : public BLECharacteristicCallbacks {
  void onWrite(BLECharacteristic* c) override {
    const std::string value = c->getValue();
    for (char ch : value) {
      const size_t next = (ring_head + 1) % kRing;
      if (next == ring_tail) return;  // full: drop the rest, the parser rejects the fragment
      ring[ring_head] = static_cast<uint8_t>(ch);
      ring_head = next;
    }
  }
};

float pid_gains[3] = {0, 0, 0};  // kp, kd, ki, as the host packs them (little-endian float32)
BLECharacteristic* state_characteristic = nullptr;
uint32_t last_state_ms = 0;
constexpr uint32_t kStatePeriodMs = 100;  // [ms]

class PidWrites : public BLECharacteristicCallbacks {
  void onWrite(BLECharacteristic* c) override {
    const std::string value = c->getValue();
    if (value.size() == sizeof(pid_gains)) memcpy(pid_gains, value.data(), sizeof(pid_gains));
  }
};

class NameWrites : public BLECharacteristicCallbacks {
  void onWrite(BLECharacteristic* c) override {
    const std::string value = c->getValue();
    if (!value.empty() && value.size() <= 20) esp_ble_gap_set_device_name(value.c_str());
  }
};

class Connections : public BLEServerCallbacks {
  void onConnect(BLEServer*) override { connected = true; }
  void onDisconnect(BLEServer* server) override {
    connected = false;
    server->getAdvertising()->start();  // let the host reconnect; the failsafe covers the gap
  }
};

void ble_begin() {
  BLEDevice::init(roar::proto::kBleLocalName);
  BLEServer* server = BLEDevice::createServer();
  server->setCallbacks(new Connections());
  // 6 characteristics x 2 handles + the service: within the default 15 handles.
  BLEService* service = server->createService(roar::proto::kBleServiceUuid);
  BLECharacteristic* control = service->createCharacteristic(
      roar::proto::kBleControlUuid, BLECharacteristic::PROPERTY_READ | BLECharacteristic::PROPERTY_WRITE |
                                        BLECharacteristic::PROPERTY_WRITE_NR);
  control->setCallbacks(new ControlWrites());
  float no_speedometer = 0.0f;  // [m/s]
  service->createCharacteristic(roar::proto::kBleVelocityUuid, BLECharacteristic::PROPERTY_READ)
      ->setValue(no_speedometer);
  service->createCharacteristic(roar::proto::kBlePidUuid, BLECharacteristic::PROPERTY_WRITE)
      ->setCallbacks(new PidWrites());
  state_characteristic = service->createCharacteristic(roar::proto::kBleStateUuid, BLECharacteristic::PROPERTY_READ);
  service->createCharacteristic(roar::proto::kBleNameUuid, BLECharacteristic::PROPERTY_WRITE)
      ->setCallbacks(new NameWrites());
  service->createCharacteristic(roar::proto::kBleOverrideUuid, BLECharacteristic::PROPERTY_WRITE);
  service->start();
  BLEAdvertising* advertising = BLEDevice::getAdvertising();
  advertising->addServiceUUID(roar::proto::kBleServiceUuid);
  advertising->start();
}

}  // namespace

void setup() {
  pinMode(pins::kStatusLed, OUTPUT);
  hal.begin();
  Serial.begin(roar::proto::kSerialBaud);
  ble_begin();
  board.begin();
}

void loop() {
  uint8_t chunk[32];
  size_t n = 0;
  while (ring_tail != ring_head && n < sizeof(chunk)) {
    chunk[n++] = ring[ring_tail];
    ring_tail = (ring_tail + 1) % kRing;
  }
  if (n) board.feed(chunk, n);
  const roar::CarOutputs out = board.poll();
  if (state_characteristic && millis() - last_state_ms >= kStatePeriodMs) {
    last_state_ms = millis();
    float payload[2] = {0.0f, static_cast<float>(out.throttle_us)};
    state_characteristic->setValue(reinterpret_cast<uint8_t*>(payload), sizeof(payload));
  }
  digitalWrite(pins::kStatusLed, connected ? LOW : HIGH);
}
