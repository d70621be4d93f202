// ROAR Junior firmware: HTTP control on port 81 exactly as the original robot takes it
// (GET /?forward=True&left_spd=0.5&right_spd=0.5, parameters applied in order, the reply body
// is the ultrasonic distance in cm), driving an L298N through roar::JuniorBoard, plus the
// failsafe the original lacked: no request for 500 ms stops the motors. Wi-Fi credentials come
// from build flags (platformio.ini, env esp32_junior).
//
// The loop never blocks: a non-blocking lwIP socket server reads each connection's bytes into
// its own fixed roar::HttpRequestReader (no String, no heap per request) and answers each
// request as soon as it is complete, keeping the connection for the next one when the client
// does (HTTP/1.1 keep-alive). When every slot is taken, a new connection replaces the one that
// has been quiet longest, so idle connections cannot lock a driver out. roar::JuniorBoard::poll()
// runs every iteration, so the failsafe fires even while a request is still arriving. The task
// watchdog resets the chip when the loop stops feeding it. Signed control: a KEY line on the USB
// serial port sets the key, kept in NVS with the session (../esp32_cam/nvs_store.h); the port is
// read only for the first serial_window_us after a reset, as the ranger needs its pins.
#include <Arduino.h>
#include <WiFi.h>
#include <errno.h>
#include <esp_task_wdt.h>
#include <fcntl.h>
#include <lwip/sockets.h>
#include <unistd.h>

#include "../esp32_cam/nvs_store.h"
#include "pins.h"
#include "roar/junior_board.h"
#include "roar/protocol.h"

#ifndef ROAR_WIFI_SSID
#define ROAR_WIFI_SSID "roar-junior"  // with no credentials the robot opens its own access point
#endif
#ifndef ROAR_WIFI_PASSWORD
#define ROAR_WIFI_PASSWORD "roarjunior"
#endif

namespace {

constexpr uint8_t kPwmBits = 10;
constexpr uint32_t kPwmFullScale = (1ul << kPwmBits) - 1;
constexpr uint32_t kPingPeriodUs = 60000;     // [us] between ultrasonic pings (echoes die out)
constexpr uint32_t kClientTimeoutMs = roar::proto::kJuniorIdleCloseUs / 1000u;  // [ms] quiet this long: closed
constexpr int kMaxClients = 4;                // connections served at once
constexpr uint32_t kWatchdogS = (roar::proto::kTimingLoopWatchdogUs + 999999ul) / 1000000ul;  // [s]

volatile uint32_t echo_rise_us = 0, echo_width_us = 0;
uint32_t last_ping_us = 0;

void IRAM_ATTR on_echo() {
  const uint32_t now = micros();
  if (digitalRead(pins::kUltrasonicEcho)) {
    echo_rise_us = now;
  } else {
    echo_width_us = now - echo_rise_us;
  }
}

void ping_if_due() {  // non-blocking: the echo is timed by the interrupt above
  const uint32_t now = micros();
  if (now - last_ping_us < kPingPeriodUs) return;
  last_ping_us = now;
  digitalWrite(pins::kUltrasonicTrigger, HIGH);
  delayMicroseconds(10);
  digitalWrite(pins::kUltrasonicTrigger, LOW);
}

void apply(const roar::SidePins& side, uint8_t in1, uint8_t in2, uint8_t channel) {
  digitalWrite(in1, side.in1 ? HIGH : LOW);
  digitalWrite(in2, side.in2 ? HIGH : LOW);
  ledcWrite(channel, side.duty * kPwmFullScale / roar::proto::kL298nDutyFullScale);
}

roar_esp32::NvsStore nvs;

class JuniorPins : public roar::JuniorHal {
 public:
  roar::RawMicros now_us() override { return micros(); }
  void write_motors(const roar::DrivePins& pins) override {
    apply(pins.left, pins::kLeftIn1, pins::kLeftIn2, pins::kLeftChannel);
    apply(pins.right, pins::kRightIn1, pins::kRightIn2, pins::kRightChannel);
  }
  void feed_watchdog() override { esp_task_wdt_reset(); }
  int read_byte() override { return console ? Serial.read() : -1; }
  void write(const char* text, size_t length) override {
    if (console && Serial.availableForWrite() >= static_cast<int>(length)) Serial.write(text, length);  // never block
  }
  roar::Nvm* nvm() override { return &nvs; }
  bool console = true;  // false once the ranger has the console's pins
};

JuniorPins hal;
roar::JuniorBoard board(hal);

struct Client {
  int fd = -1;
  uint32_t active_ms = 0;  // [ms] when it last sent a byte (or was accepted)
  roar::HttpRequestReader request;
};
int listener = -1;
Client clients[kMaxClients];

void server_begin() {
  listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr = {};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(roar::proto::kJuniorControlPort);
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  listen(listener, kMaxClients);
  fcntl(listener, F_SETFL, O_NONBLOCK);
}

void finish(Client& c) {
  close(c.fd);
  c.fd = -1;
}

void serve(Client& c) {  // read what has arrived; answer each request as soon as it is decided
  uint8_t bytes[64];
  const int n = recv(c.fd, bytes, sizeof(bytes), 0);
  if (n == 0 || (n < 0 && errno != EWOULDBLOCK && errno != EAGAIN)) return finish(c);  // peer gone
  if (n > 0) c.active_ms = millis();
  for (int i = 0; i < n; ++i) {
    if (c.request.feed(bytes[i]) == roar::HttpRead::Incomplete) continue;
    char reply[roar::JuniorBoard::kMaxReplyBytes];
    bool keep_open = false;
    const size_t len = board.respond(c.request, roar::echo_us_to_cm(echo_width_us), reply, sizeof(reply), &keep_open);
    send(c.fd, reply, len, 0);  // a short reply fits the socket's buffer; never waited for
    if (!keep_open) return finish(c);
    c.request.reset();  // the next request on this connection (pipelined bytes follow at once)
  }
  if (millis() - c.active_ms > kClientTimeoutMs) finish(c);
}

void server_poll() {
  const int fd = accept(listener, nullptr, nullptr);
  if (fd >= 0) {  // a free slot, or else the one quiet longest
    Client* slot = &clients[0];
    for (Client& c : clients) {
      if (c.fd < 0) {
        slot = &c;
        break;
      }
      if (c.active_ms - slot->active_ms > 0x7FFFFFFFu) slot = &c;  // quieter than the best so far
    }
    if (slot->fd >= 0) finish(*slot);
    fcntl(fd, F_SETFL, O_NONBLOCK);
    slot->fd = fd;
    slot->active_ms = millis();
    slot->request.reset();
  }
  for (Client& c : clients) {
    if (c.fd >= 0) serve(c);
  }
}

}  // namespace

void setup() {
  for (uint8_t pin : {pins::kLeftIn1, pins::kLeftIn2, pins::kRightIn1, pins::kRightIn2}) {
    pinMode(pin, OUTPUT);
    digitalWrite(pin, LOW);
  }
  ledcSetup(pins::kLeftChannel, roar::proto::kL298nPwmFrequencyHz, kPwmBits);
  ledcSetup(pins::kRightChannel, roar::proto::kL298nPwmFrequencyHz, kPwmBits);
  ledcAttachPin(pins::kEnableLeft, pins::kLeftChannel);
  ledcAttachPin(pins::kEnableRight, pins::kRightChannel);
  Serial.begin(roar::proto::kSerialBaud);
  nvs.begin();
  board.begin();
  // The ranger sits on the console's pins: key lines are read for a window after the reset
  // (motors stopped, no network yet), then the pins are the ranger's.
  for (const uint32_t start = millis(); millis() - start < roar::proto::kJuniorSerialWindowUs / 1000;) board.poll();
  Serial.flush();
  Serial.end();
  hal.console = false;
  pinMode(pins::kUltrasonicTrigger, OUTPUT);
  pinMode(pins::kUltrasonicEcho, INPUT);
  attachInterrupt(digitalPinToInterrupt(pins::kUltrasonicEcho), on_echo, CHANGE);
  WiFi.begin(ROAR_WIFI_SSID, ROAR_WIFI_PASSWORD);
  for (int i = 0; i < 100 && WiFi.status() != WL_CONNECTED; ++i) delay(100);
  if (WiFi.status() != WL_CONNECTED) WiFi.softAP(ROAR_WIFI_SSID, ROAR_WIFI_PASSWORD);
  server_begin();
  esp_task_wdt_init(kWatchdogS, true);  // panic -> reset
  esp_task_wdt_add(nullptr);            // this task, the loop
}

void loop() {
  server_poll();
  ping_if_due();
  board.poll();
}
