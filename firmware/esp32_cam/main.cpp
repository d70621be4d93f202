// The car firmware for the ESP32-CAM: BLE (the ESP32 Arduino core's BLE library) and USB serial
// into roar::CarBoard; 50 Hz servo pulses from the LEDC peripheral on GPIO14 (ESC) and GPIO2
// (steering). Built with PlatformIO (env esp32cam; arduino-esp32 2.x, ESP-IDF 4.4).
//
//   - Frames are counted by LEDC's own overflow interrupt: a new duty takes effect when the
//     timer overflows, so each interrupt is a frame that really started (the brake sequence
//     relies on it).
//   - BLE writes arrive on the Bluetooth task and reach the loop through roar::SpscBytes
//     (acquire/release ordering, whole writes only).
//   - The task watchdog resets the chip when the loop stops feeding it.
//
// The ROAR GATT layout (PROTOCOL.md section 4): control (write, write without response),
// velocity (read, 0: no speedometer here), pid (write, 3 x float32, kept), state (read: speed 0,
// throttle output [us] as float32), name (write: advertised from the next start of advertising,
// not persisted), override (write: accepted; this board has no override output), session (read:
// uint32 session, uint32 last counter: signed control). The signing key and session live in NVS
// (the Preferences library, namespace "roar"), behind the core's Nvm. With a key, control and
// session need an LE Secure Connections link (BLESecurity, Just Works, bonded).
#include <Arduino.h>
#include <BLEDevice.h>
#include <BLESecurity.h>
#include <BLEServer.h>
#include <driver/ledc.h>
#include <esp_gap_ble_api.h>
#include <esp_task_wdt.h>
#include <soc/ledc_struct.h>
#include <string.h>

#include <atomic>

#include "nvs_store.h"
#include "pins.h"
#include "roar/car_board.h"
#include "roar/protocol.h"
#include "roar/spsc_bytes.h"

namespace {

constexpr uint32_t kFrameHz = 1000000ul / roar::proto::kTimingServoFrameUs;  // [Hz] 50
constexpr uint8_t kLedcBits = 16;
constexpr uint32_t kLedcFullScale = (1ul << kLedcBits) - 1;
// arduino-esp32 maps LEDC channel c to speed group c / 8 and timer (c / 2) % 4: channels 2 and 3
// are high-speed timer 1, whose overflow interrupt is hstimer1_ovf below.
static_assert(pins::kThrottleChannel / 8 == 0 && (pins::kThrottleChannel / 2) % 4 == 1 &&
                  pins::kSteeringChannel / 8 == 0 && (pins::kSteeringChannel / 2) % 4 == 1,
              "both outputs on LEDC high-speed timer 1");
// The task watchdog counts whole seconds here: round the spec's loop watchdog up.
constexpr uint32_t kWatchdogS = (roar::proto::kTimingLoopWatchdogUs + 999999ul) / 1000000ul;  // [s]

std::atomic<uint32_t> frames{0};  // written by the LEDC interrupt only

void IRAM_ATTR on_ledc_interrupt(void*) {
  if (LEDC.int_st.hstimer1_ovf) {
    LEDC.int_clr.hstimer1_ovf = 1;
    frames.store(frames.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
}

uint32_t duty_for(uint16_t pulse_us) {  // [LEDC counts] for a pulse in a 20 ms frame
  return static_cast<uint32_t>(pulse_us) * kLedcFullScale / roar::proto::kTimingServoFrameUs;
}

roar_esp32::NvsStore nvs;

class Esp32Hal : public roar::Hal {
 public:
  void begin() {
    ledcSetup(pins::kThrottleChannel, kFrameHz, kLedcBits);
    ledcSetup(pins::kSteeringChannel, kFrameHz, kLedcBits);
    ledcAttachPin(pins::kThrottleOut, pins::kThrottleChannel);
    ledcAttachPin(pins::kSteeringOut, pins::kSteeringChannel);
    write_pulses(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
    ledc_isr_register(on_ledc_interrupt, nullptr, ESP_INTR_FLAG_IRAM, nullptr);
    LEDC.int_clr.hstimer1_ovf = 1;
    LEDC.int_ena.hstimer1_ovf = 1;
  }
  roar::RawMicros now_us() override { return micros(); }
  // LEDC takes a new duty at the end of the current period, i.e. at the next frame start.
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override {
    ledcWrite(pins::kThrottleChannel, duty_for(throttle_us));
    ledcWrite(pins::kSteeringChannel, duty_for(steering_us));
  }
  uint32_t frames_started() override { return frames.load(std::memory_order_relaxed); }
  int read_byte() override { return Serial.read(); }
  size_t write_room() override { return static_cast<size_t>(Serial.availableForWrite()); }
  void write(const char* text, size_t length) override { Serial.write(text, length); }
  void feed_watchdog() override { esp_task_wdt_reset(); }
  roar::Nvm* nvm() override { return &nvs; }
};

Esp32Hal hal;
roar::CarBoard board(hal);

// BLE writes arrive on the Bluetooth task; the loop takes them from here.
roar::SpscBytes<256> ble_bytes;
std::atomic<bool> connected{false};

class ControlWrites : public BLECharacteristicCallbacks {
  void onWrite(BLECharacteristic* c) override {
    const std::string value = c->getValue();
    ble_bytes.push(reinterpret_cast<const uint8_t*>(value.data()), value.size());  // whole, or dropped
  }
};

float pid_gains[3] = {0, 0, 0};  // kp, kd, ki, as the host packs them (little-endian float32)
BLECharacteristic* state_characteristic = nullptr;
BLECharacteristic* session_characteristic = nullptr;
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

// secure (the car has a key): control and session need an encrypted link, paired with LE Secure
// Connections only, Just Works (no display, no keys), bonded. A signing host pairs by itself.
void ble_begin(bool secure) {
  BLEDevice::init(roar::proto::kBleLocalName);
  if (secure) {
    BLESecurity security;
    security.setAuthenticationMode(ESP_LE_AUTH_REQ_SC_BOND);
    security.setCapability(ESP_IO_CAP_NONE);
    security.setInitEncryptionKey(ESP_BLE_ENC_KEY_MASK | ESP_BLE_ID_KEY_MASK);
    security.setRespEncryptionKey(ESP_BLE_ENC_KEY_MASK | ESP_BLE_ID_KEY_MASK);
  }
  BLEServer* server = BLEDevice::createServer();
  server->setCallbacks(new Connections());
  // 7 characteristics x 2 handles + the service: the default 15 handles.
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
  session_characteristic = service->createCharacteristic(roar::proto::kBleSessionUuid, BLECharacteristic::PROPERTY_READ);
  if (secure) {
    control->setAccessPermissions(ESP_GATT_PERM_READ_ENCRYPTED | ESP_GATT_PERM_WRITE_ENCRYPTED);
    session_characteristic->setAccessPermissions(ESP_GATT_PERM_READ_ENCRYPTED);
  }
  service->start();
  BLEAdvertising* advertising = BLEDevice::getAdvertising();
  advertising->addServiceUUID(roar::proto::kBleServiceUuid);
  advertising->start();
}

}  // namespace

void setup() {
  pinMode(pins::kStatusLed, OUTPUT);
  hal.begin();
  nvs.begin();
  Serial.begin(roar::proto::kSerialBaud);
  board.begin();                               // the key first: it decides the link's security
  ble_begin(board.car().auth().keyed());       // (a key set later takes effect from the next reset)
  esp_task_wdt_init(kWatchdogS, true);  // panic -> reset
  esp_task_wdt_add(nullptr);            // this task, the loop
}

void loop() {
  uint8_t chunk[roar::CarBoard::kMaxBytesPerPoll];  // a bounded share per loop, as for serial
  const size_t n = ble_bytes.pop(chunk, sizeof(chunk));
  if (n) board.feed(chunk, n);
  const roar::CarOutputs out = board.poll();
  if (state_characteristic && millis() - last_state_ms >= kStatePeriodMs) {
    last_state_ms = millis();
    float payload[2] = {0.0f, static_cast<float>(out.throttle_us)};
    state_characteristic->setValue(reinterpret_cast<uint8_t*>(payload), sizeof(payload));
    uint32_t signing[2] = {board.car().auth().session(), board.car().auth().last_counter()};  // little-endian
    session_characteristic->setValue(reinterpret_cast<uint8_t*>(signing), sizeof(signing));
  }
  digitalWrite(pins::kStatusLed, connected ? LOW : HIGH);
}
