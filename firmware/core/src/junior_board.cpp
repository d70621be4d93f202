#include "roar/junior_board.h"

#include "roar/protocol.h"
#include "roar/text.h"

namespace roar {
namespace {

size_t reply(char* out, size_t cap, const char* status, const char* body) {
  size_t body_len = 0;
  while (body[body_len]) ++body_len;
  size_t len = 0;
  const bool ok = append(out, cap, &len, "HTTP/1.1 ") && append(out, cap, &len, status) &&
                  append(out, cap, &len, "\r\nContent-Type: text/plain\r\nContent-Length: ") &&
                  append_uint(out, cap, &len, static_cast<uint32_t>(body_len)) &&
                  append(out, cap, &len, "\r\nConnection: close\r\n\r\n") && append(out, cap, &len, body);
  return ok ? len : 0;
}

}  // namespace

size_t JuniorBoard::respond(const HttpRequestReader& request, uint32_t distance_cm, char* out, size_t cap) {
  if (cap < kMaxReplyBytes) return 0;
  switch (request.state()) {
    case HttpRead::Incomplete:
      return 0;
    case HttpRead::Malformed:
      return reply(out, cap, "400 Bad Request", "not an HTTP/1.x request\n");
    case HttpRead::TooLong:
      return reply(out, cap, "414 URI Too Long", "request too long\n");
    case HttpRead::Complete:
      break;
  }
  if (!equals(request.method(), request.method_length(), "GET")) {
    return reply(out, cap, "405 Method Not Allowed", "only GET\n");
  }
  if (!equals(request.path(), request.path_length(), proto::kJuniorControlRoute)) {
    return reply(out, cap, "404 Not Found", "no such route\n");
  }
  control_.apply_query(request.query(), request.query_length(), now());
  char distance[11];
  size_t n = 0;
  append_uint(distance, sizeof(distance), &n, distance_cm);
  return reply(out, cap, "200 OK", distance);
}

DrivePins JuniorBoard::poll() {
  const Micros t = now();
  const DrivePins pins = driver_.step(control_.duties(t), t);
  hal_.write_motors(pins);
  hal_.feed_watchdog();
  return pins;
}

}  // namespace roar
