// The ROAR Junior's loop, the same on the robot and in the simulator: HTTP requests (read by
// HttpRequestReader, one per connection, by the board's non-blocking server) go through
// JuniorControl; every loop iteration turns its duties into L298N pins with the reversal dead
// time, writes them, and feeds the hardware watchdog. The 500 ms failsafe lives in the loop, not
// in the server, so it fires even while a request is still arriving.
//
// Signed control (PROTOCOL.md 1.3 and 6): with a key (set by a KEY line on the USB serial port,
// kept in the board's Nvm) the control route acts only on queries that end with a counter and
// a MAC, "...&ctr=HEX&mac=HEX12"; others are refused 403 with the reason and change nothing
// (the failsafe is not fed).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/clock.h"
#include "roar/http_request.h"
#include "roar/junior_control.h"
#include "roar/l298n_driver.h"
#include "roar/signing.h"

namespace roar {

class JuniorHal {
 public:
  virtual RawMicros now_us() = 0;                       // the free-running 32-bit counter (wraps)
  virtual void write_motors(const DrivePins& pins) = 0;  // both sides' direction pins and duty
  virtual void feed_watchdog() = 0;                     // the loop is alive
  // The USB serial port, where a key is set (KEY lines): the next byte or -1, and a reply line.
  virtual int read_byte() { return -1; }
  virtual void write(const char* text, size_t length) { (void)text, (void)length; }
  // Where the key and the session counter live; nullptr: nowhere (the board takes no key).
  virtual Nvm* nvm() { return nullptr; }

 protected:
  ~JuniorHal() = default;
};

class JuniorBoard {
 public:
  static const size_t kMaxReplyBytes = 256;  // [bytes] the longest response respond() writes
  static const uint8_t kMaxQuotedBytes = 40;  // [bytes] of a refused parameter quoted in a 400

  explicit JuniorBoard(JuniorHal& hal) : hal_(hal) {}

  // Call once the serial port is up: reads the key (a fresh session), says SESSION when keyed.
  void begin();

  // The response to a finished read (any state but Incomplete), NUL-terminated in out; returns
  // its length, or 0 when cap is below kMaxReplyBytes. A GET of the control route applies its
  // query (parameters in order) and answers 200 with distance_cm as the body; a query with a
  // parameter that is not understood and whatever refuse() refuses get 400 or 405, other paths
  // 404, each with a one-line reason as the body, and change nothing. *keep_open
  // says whether the connection stays open for the next request (a 200 to a client that keeps
  // its connection).
  size_t respond(const HttpRequestReader& request, uint32_t distance_cm, char* out, size_t cap, bool* keep_open);

  // The rules every port of the Junior applies before its routes, as respond() applies them: the
  // response (NUL-terminated in out; the connection then closes) to a finished read that is
  // malformed or too long (400), not a GET (405) or a GET that declares a body (400); 0 for a
  // GET without a body, which the port's routes answer. Also 0 when cap is below kMaxReplyBytes.
  static size_t refuse(const HttpRequestReader& request, char* out, size_t cap);

  // The loop body: serial key lines, failsafe, L298N pins with dead time, pins written, watchdog fed.
  DrivePins poll();

  const JuniorControl& control() const { return control_; }
  const Authenticator& auth() const { return keys_.auth(); }

 private:
  Micros now() { return clock_.extend(hal_.now_us()); }

  JuniorHal& hal_;
  MonotonicClock clock_;
  void serial_line(const char* text, size_t n) { hal_.write(text, n); }

  JuniorControl control_;
  L298nDriver driver_;
  KeyStore keys_;
  KeyLine key_line_;
};

}  // namespace roar
