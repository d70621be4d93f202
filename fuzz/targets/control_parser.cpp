// The control and setpoint parser (roar/control_parser.h), byte by byte and by buffer: both
// give the same events at the same bytes; a message is only ever reported in range (pulses
// kControlMinUs..kControlMaxUs, a setpoint's speed within kSetpointMaxSpeedMmS); every result
// is one of the spec's.
#include <vector>

#include "harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::Object bytewise(roar_parser_size()), buffered(roar_parser_size());
  roar_parser_init(bytewise);
  roar_parser_init(buffered);
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
  }
  CHECK(k == n);
  return 0;
}
