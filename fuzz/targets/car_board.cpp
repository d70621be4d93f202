// The ESC car's board loop (CarBoard on the host HAL) fed a serial stream and BLE writes: its
// pulses stay within kControlMinUs..kControlMaxUs, its replies fit the transmit buffer, and
// after the input ends and the failsafe timeout passes it is back at neutral.
#include "harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  roar_car_config_t config;
  roar_car_default_config(&config);
  roar_host_hal_t hal = {};
  hal.loop_us = 1000;
  hal.frame_us = 20000;
  fuzz::Object board(roar_board_size());
  CHECK(roar_board_init(board, &hal, &config) == 0);
  roar_board_begin(board);
  size_t at = 0;
  while (at < size) {
    // a chunk: the first byte says how long and where (serial, or a BLE write)
    const uint8_t head = data[at++];
    size_t n = head & 0x3f;
    if (n > size - at) n = size - at;
    if (head & 0x40) {
      roar_board_feed(board, data + at, n);
    } else {
      for (size_t i = 0; i < n && hal.rx_len < ROAR_HOST_RX_BYTES; ++i) hal.rx[hal.rx_len++] = data[at + i];
    }
    at += n;
    roar_board_run(board, 1 + (head >> 7) * 20);
    if (hal.rx_pos == hal.rx_len) hal.rx_pos = hal.rx_len = 0;
    CHECK(hal.tx_len <= ROAR_HOST_TX_BYTES);
    hal.tx_len = 0;
    CHECK(fuzz::pulse_ok(hal.wire_us[0]) && fuzz::pulse_ok(hal.wire_us[1]));
    CHECK(fuzz::pulse_ok(hal.pending_us[0]) && fuzz::pulse_ok(hal.pending_us[1]));
  }
  roar_board_run(board, 600);  // 0.6 s of silence: the failsafe has set neutral
  CHECK(hal.pending_us[0] == fuzz::proto::kControlNeutralUs);
  return 0;
}
