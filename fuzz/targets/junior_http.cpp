// The Junior's HTTP side: one connection's bytes read request by request (roar/http_request.h)
// and answered by its board (roar/junior_board.h), with its loop run between requests. A read
// never takes more bytes than given; every reply is NUL-terminated and at most
// roar_junior_reply_max() long; the motor driver never has both direction pins of a side high
// and never a duty beyond full scale.
#include <string.h>

#include <vector>

#include "harness.h"

static void check_side(const roar_side_pins_t& s) {
  CHECK(!(s.in1 && s.in2));
  CHECK(s.duty <= fuzz::proto::kL298nDutyFullScale);
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  roar_junior_hal_t hal = {};
  hal.loop_us = 1000;
  hal.distance_cm = 42;
  fuzz::Object board(roar_junior_board_size()), reader(roar_http_reader_size());
  roar_junior_board_init(board, &hal);
  roar_http_reader_init(reader);
  const size_t cap = roar_junior_reply_max() + 1;
  std::vector<char> reply(cap + 16);
  size_t at = 0;
  while (at < size) {
    uint8_t state = 0;
    const size_t took = roar_http_reader_feed(reader, data + at, size - at, &state);
    CHECK(took <= size - at);
    at += took;
    if (state == 0) break;  // incomplete: the connection's bytes ran out
    memset(reply.data(), 'x', reply.size());
    uint8_t keep_open = 0;
    const size_t n = roar_junior_board_respond(board, reader, reply.data(), cap, &keep_open);
    CHECK(n < cap && n <= roar_junior_reply_max());
    CHECK(reply[n] == '\0' && strlen(reply.data()) == n);
    const size_t refused = roar_http_refuse(reader, reply.data(), cap);
    CHECK(refused < cap && (refused == 0 || reply[refused] == '\0'));  // 0: a GET its routes answer
    roar_junior_board_run(board, 7);
    check_side(hal.left);
    check_side(hal.right);
    if (!keep_open) break;
    roar_http_reader_init(reader);
    if (took == 0) break;
  }
  roar_junior_board_run(board, 600);  // past the failsafe: both sides stop
  check_side(hal.left);
  check_side(hal.right);
  CHECK(hal.left.duty == 0 && hal.right.duty == 0);
  return 0;
}
