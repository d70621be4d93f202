// The control and setpoint parser (roar/control_parser.h), byte by byte and by buffer: both
// give the same events at the same bytes; a message is only ever reported in range (pulses
// kControlMinUs..kControlMaxUs, a setpoint's speed within kSetpointMaxSpeedMmS); every result
// is one of the spec's. Each message also goes to a keyed and an unkeyed authenticator: the keyed
// one takes only a signed message whose MAC is its key's over its session and whose counter is
// above the last it took; the unkeyed one refuses exactly the signed messages (nokey).
#include <vector>

#include "harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::Object bytewise(roar_parser_size()), buffered(roar_parser_size());
  roar_parser_init(bytewise);
  roar_parser_init(buffered);
  static const uint8_t key[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  const uint32_t session = 0x2A;  // the signed golden vectors' key and session: their messages pass
  fuzz::Object keyed(roar_auth_size()), unkeyed(roar_auth_size());
  roar_auth_init(keyed);
  roar_auth_init(unkeyed);
  roar_auth_set_key(keyed, key, session);
  std::vector<roar_parse_event_t> events(size + 1);
  const size_t n = roar_parser_feed_buffer(buffered, data, size, events.data(), events.size());
  CHECK(n <= size);
  size_t k = 0;
  for (size_t i = 0; i < size; ++i) {
    uint16_t throttle = 0, steering = 0;
    const uint8_t r = roar_parser_feed(bytewise, data[i], &throttle, &steering);
    CHECK(r < fuzz::kParseResultCount);
    if (r == 0) continue;
    CHECK(k < n);
    const roar_parse_event_t& e = events[k++];
    CHECK(e.at == i && e.result == r);
    if (r == static_cast<uint8_t>(fuzz::ParseResult::Ok)) {
      CHECK(fuzz::pulse_ok(throttle) && fuzz::pulse_ok(steering));
      CHECK(e.throttle == throttle && e.steering == steering);
    }
    if (r == static_cast<uint8_t>(fuzz::ParseResult::Setpoint)) {
      CHECK(fuzz::pulse_ok(e.steering));
      CHECK(e.speed_mm_s >= -static_cast<int>(fuzz::proto::kSetpointMaxSpeedMmS) &&
            e.speed_mm_s <= static_cast<int>(fuzz::proto::kSetpointMaxSpeedMmS));
    }
    if (r == static_cast<uint8_t>(fuzz::ParseResult::Ok) || r == static_cast<uint8_t>(fuzz::ParseResult::Setpoint)) {
      const bool setpoint = r == static_cast<uint8_t>(fuzz::ParseResult::Setpoint);
      const uint32_t before = roar_auth_last_counter(keyed);
      const uint8_t verdict = roar_auth_check(keyed, r, bytewise);
      const uint8_t no_key = roar_auth_check(unkeyed, r, bytewise);
      CHECK(no_key == (e.is_signed ? static_cast<uint8_t>(fuzz::ParseResult::Nokey) : r));
      if (verdict == r) {  // taken: a signed message with the right MAC and a higher counter
        const int16_t first = setpoint ? e.speed_mm_s : static_cast<int16_t>(e.throttle);
        CHECK(e.is_signed && e.counter > before);
        CHECK(roar_message_mac(key, session, setpoint ? '[' : '(', first, e.steering, e.counter) == e.mac);
        CHECK(roar_auth_last_counter(keyed) == e.counter);
      } else {  // refused, with a reason, and nothing changed
        CHECK(verdict == static_cast<uint8_t>(fuzz::ParseResult::Unsigned) ||
              verdict == static_cast<uint8_t>(fuzz::ParseResult::Forged) ||
              verdict == static_cast<uint8_t>(fuzz::ParseResult::Replay));
        CHECK(e.is_signed == (verdict != static_cast<uint8_t>(fuzz::ParseResult::Unsigned)));
        CHECK(roar_auth_last_counter(keyed) == before);
      }
    }
  }
  CHECK(k == n);
  return 0;
}
