// The IARRC car's tasks (IarrcBoard on the host HAL) fed the vision computer's bytes, the
// Bluetooth module's bytes and SBUS bytes: its pulses stay within kControlMinUs..kControlMaxUs,
// its lines fit their buffers, and every line it writes ends in a line end.
#include <string.h>

#include "harness.h"

static void check_lines(const char* tx, uint16_t len) {
  CHECK(len <= ROAR_IARRC_TX_BYTES);
  if (len > 0) CHECK(tx[len - 1] == '\n');
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static roar_iarrc_hal_t hal;
  memset(&hal, 0, sizeof hal);
  memset(hal.flash.bytes, 0xFF, sizeof hal.flash.bytes);  // blank flash, as from the factory
  hal.flash.power_words = -1;                              // that never loses power
  hal.battery_adc = 3000;
  fuzz::Object board(roar_iarrc_board_size());
  roar_iarrc_board_init(board, &hal, 0);
  roar_iarrc_board_begin(board);
  const uint8_t tasks = roar_iarrc_task_count();
  size_t at = 0;
  while (at < size) {
    const uint8_t head = data[at++];  // where the next bytes go, how many, which task runs after
    size_t n = head & 0x1f;
    if (n > size - at) n = size - at;
    const uint8_t where = (head >> 5) & 3;
    for (size_t i = 0; i < n; ++i) {
      const uint8_t b = data[at + i];
      if (where == 0 && hal.host_len < ROAR_IARRC_RX_BYTES) hal.host_rx[hal.host_len++] = b;
      if (where == 1 && hal.link_len < ROAR_IARRC_RX_BYTES) hal.link_rx[hal.link_len++] = b;
      if (where >= 2 && hal.sbus_len < ROAR_IARRC_SBUS_BYTES) {
        hal.sbus_at_us[hal.sbus_len] = hal.now_us + 120u * i;
        hal.sbus[hal.sbus_len++] = b;
      }
    }
    at += n;
    hal.now_us += 1000u * (1 + (head >> 7) * 9);
    ++hal.frames_started;
    for (uint8_t t = 0; t < tasks; ++t) roar_iarrc_board_run(board, t);
    CHECK(hal.host_pos <= hal.host_len && hal.link_pos <= hal.link_len && hal.sbus_pos <= hal.sbus_len);
    if (hal.host_pos == hal.host_len) hal.host_pos = hal.host_len = 0;
    if (hal.link_pos == hal.link_len) hal.link_pos = hal.link_len = 0;
    if (hal.sbus_pos == hal.sbus_len) hal.sbus_pos = hal.sbus_len = 0;
    check_lines(hal.host_tx, hal.host_tx_len);
    check_lines(hal.link_tx, hal.link_tx_len);
    hal.host_tx_len = hal.link_tx_len = 0;
    CHECK(fuzz::pulse_ok(hal.throttle_us) && fuzz::pulse_ok(hal.steering_us));
  }
  return 0;
}
