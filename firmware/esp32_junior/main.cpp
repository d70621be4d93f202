// ROAR Junior firmware: HTTP control on port 81 exactly as the original robot takes it
// (GET /?forward=True&left_spd=0.5&right_spd=0.5, parameters applied in order, the reply body
// is the ultrasonic distance in cm), driving an L298N through roar::JuniorControl and
// roar::L298nDriver, plus the failsafe the original lacked: no request for 500 ms stops the
// motors. Wi-Fi credentials come from build flags (platformio.ini, env esp32_junior).
#include <Arduino.h>
#include <WebServer.h>
#include <WiFi.h>

#include "pins.h"
#include "roar/junior_control.h"
#include "roar/l298n_mixer.h"
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
constexpr uint32_t kPingPeriodUs = 60000;  // [us] between ultrasonic pings (echoes die out)

WebServer server(roar::proto::kJuniorControlPort);
roar::JuniorControl control;
roar::L298nDriver driver;

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

void handle_control() {
  // WebServer keeps the query parameters in request order: rebuild "a=b&c=d" for the core.
  char query[256];
  size_t n = 0;
  for (int i = 0; i < server.args() && n < sizeof(query) - 1; ++i) {
    const String item = (i ? "&" : "") + server.argName(i) + "=" + server.arg(i);
    for (size_t k = 0; k < item.length() && n < sizeof(query) - 1; ++k) query[n++] = item[k];
  }
  query[n] = '\0';
  control.apply_query(query, n, micros());
  server.send(200, "text/plain", String(roar::echo_us_to_cm(echo_width_us)));
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
  pinMode(pins::kUltrasonicTrigger, OUTPUT);
  pinMode(pins::kUltrasonicEcho, INPUT);
  attachInterrupt(digitalPinToInterrupt(pins::kUltrasonicEcho), on_echo, CHANGE);

  WiFi.begin(ROAR_WIFI_SSID, ROAR_WIFI_PASSWORD);
  for (int i = 0; i < 100 && WiFi.status() != WL_CONNECTED; ++i) delay(100);
  if (WiFi.status() != WL_CONNECTED) WiFi.softAP(ROAR_WIFI_SSID, ROAR_WIFI_PASSWORD);
  server.on(roar::proto::kJuniorControlRoute, HTTP_GET, handle_control);
  server.begin();
}

void loop() {
  server.handleClient();
  ping_if_due();
  const uint32_t now = micros();
  const roar::DrivePins out = driver.step(control.duties(now), now);
  apply(out.left, pins::kLeftIn1, pins::kLeftIn2, pins::kLeftChannel);
  apply(out.right, pins::kRightIn1, pins::kRightIn2, pins::kRightChannel);
}
