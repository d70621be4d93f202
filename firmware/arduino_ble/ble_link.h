// The ROAR GATT service on boards with Bluetooth LE (Nano 33 BLE); a no-op elsewhere.
#pragma once
#include "roar/car_board.h"

namespace ble_link {
void begin();                                   // advertise the ROAR service as "ROAR Car"
void poll(roar::CarBoard& board);               // hand every control write to the board
void publish(const roar::CarBoard& board, const roar::CarOutputs& outputs);  // refresh the readable state and session characteristics
}  // namespace ble_link
