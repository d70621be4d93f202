#include "roar/junior_board.h"

#include "roar/protocol.h"
#include "roar/signing.h"
#include "roar/text.h"

namespace roar {
namespace {

size_t reply(char* out, size_t cap, const char* status, const char* body, bool keep_open) {
  size_t body_len = 0;
  while (body[body_len]) ++body_len;
  size_t len = 0;
  const bool ok = append(out, cap, &len, "HTTP/1.1 ") && append(out, cap, &len, status) &&
                  append(out, cap, &len, "\r\nContent-Type: text/plain\r\nContent-Length: ") &&
                  append_uint(out, cap, &len, static_cast<uint32_t>(body_len)) &&
                  append(out, cap, &len, keep_open ? "\r\nConnection: keep-alive\r\n\r\n" : "\r\nConnection: close\r\n\r\n") &&
                  append(out, cap, &len, body);
  return ok ? len : 0;
}

const char* reason(JuniorQueryError error) {
  switch (error) {
    case JuniorQueryError::UnknownName: return "unknown parameter";
    case JuniorQueryError::BadFlag: return "a flag takes True or False";
    case JuniorQueryError::BadSpeed: return "a speed takes a number 0..1";
    case JuniorQueryError::None: break;
  }
  return "";
}

}  // namespace

size_t JuniorBoard::refuse(const HttpRequestReader& request, char* out, size_t cap) {
  if (cap < kMaxReplyBytes) return 0;
  switch (request.state()) {
    case HttpRead::Incomplete:
      return 0;
    case HttpRead::Malformed:
      return reply(out, cap, "400 Bad Request", "not an HTTP/1.x request\n", false);
    case HttpRead::TooLong:
      return reply(out, cap, "400 Bad Request", "request too long\n", false);
    case HttpRead::Complete:
      break;
  }
  if (!equals(request.method(), request.method_length(), "GET")) {
    return reply(out, cap, "405 Method Not Allowed", "only GET\n", false);
  }
  if (request.has_body()) return reply(out, cap, "400 Bad Request", "a GET takes no body\n", false);
  return 0;
}

size_t JuniorBoard::respond(const HttpRequestReader& request, uint32_t distance_cm, char* out, size_t cap,
                            bool* keep_open) {
  *keep_open = false;
  if (cap < kMaxReplyBytes || request.state() == HttpRead::Incomplete) return 0;
  const size_t refused = refuse(request, out, cap);
  if (refused) return refused;
  if (!equals(request.path(), request.path_length(), proto::kJuniorControlRoute)) {
    return reply(out, cap, "404 Not Found", "no such route\n", false);
  }
  char body[kMaxQuotedBytes + 48];
  size_t n = 0;
  size_t apply_length = 0;
  const ParseResult verdict = keys_.auth().check_query(request.query(), request.query_length(), &apply_length);
  if (verdict != ParseResult::Ok) {  // "<reason> [session or counter]": as the serial ERR line says it
    append_refusal(body, sizeof(body), &n, verdict, refusal_value(verdict, keys_.auth()));
    append(body, sizeof(body), &n, "\n");
    return reply(out, cap, verdict == ParseResult::Syntax ? "400 Bad Request" : "403 Forbidden", body, false);
  }
  const JuniorQueryResult r = control_.apply_query(request.query(), apply_length, now());
  if (r.error != JuniorQueryError::None) {  // "<reason>: '<name=value>'", the parameter cut to fit
    char quoted[kMaxQuotedBytes + 1];
    size_t q = 0;
    for (; q < r.bad_length && q < kMaxQuotedBytes; ++q) quoted[q] = request.query()[r.bad_at + q];
    quoted[q] = '\0';
    append(body, sizeof(body), &n, reason(r.error));
    append(body, sizeof(body), &n, ": '");
    append(body, sizeof(body), &n, quoted);
    append(body, sizeof(body), &n, "'\n");
    return reply(out, cap, "400 Bad Request", body, false);
  }
  append_uint(body, sizeof(body), &n, distance_cm);
  *keep_open = request.keep_alive();
  return reply(out, cap, "200 OK", body, *keep_open);
}

void JuniorBoard::begin() {
  keys_.boot(hal_.nvm());
  if (keys_.auth().keyed()) {
    char line[proto::kSerialMaxReplyBytes + 1];
    size_t n = 0;
    if (append_session_reply(line, sizeof(line), &n, keys_.auth())) serial_line(line, n);
  }
}

DrivePins JuniorBoard::poll() {
  for (uint8_t i = 0; i < 64; ++i) {  // the serial port carries key lines only
    const int byte = hal_.read_byte();
    if (byte < 0) break;
    const KeyLine::Event ev = key_line_.feed(static_cast<uint8_t>(byte));
    if (ev == KeyLine::Event::NotMine || ev == KeyLine::Event::Taken) continue;
    char line[2 * proto::kSerialMaxReplyBytes + 1];  // KEY and SESSION
    const size_t n = keys_.on_key_line(ev, key_line_.key(), line, sizeof(line));
    if (n) serial_line(line, n);
  }
  const Micros t = now();
  const DrivePins pins = driver_.step(control_.duties(t), t);
  hal_.write_motors(pins);
  hal_.feed_watchdog();
  return pins;
}

}  // namespace roar
