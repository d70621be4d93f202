#include "roar/car_board.h"

namespace roar {

void CarBoard::feed(const uint8_t* data, size_t length) {
  const Micros t = now();
  car_.feed(data, length, t, Link::Radio);
}

CarOutputs CarBoard::poll() {
  const Micros t = now();
  uint8_t received[kMaxBytesPerPoll];
  uint8_t n = 0;
  for (; n < kMaxBytesPerPoll; ++n) {
    const int byte = hal_.read_byte();
    if (byte < 0) break;
    received[n] = static_cast<uint8_t>(byte);
  }
  car_.feed(received, n, t);
  const CarOutputs out = car_.step(t, hal_.frames_started());
  hal_.write_pulses(out.throttle_us, out.steering_us);
  char line[proto::kSerialMaxReplyBytes + 1];
  // A reply is written only when it fits whole: the loop never blocks on a slow host.
  while (hal_.write_room() >= proto::kSerialMaxReplyBytes) {
    const size_t n = car_.take_reply(line, sizeof(line));
    if (n == 0) break;
    hal_.write(line, n);
  }
  hal_.feed_watchdog();
  return out;
}

}  // namespace roar
