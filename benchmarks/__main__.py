"""Run all benchmarks: python -m benchmarks"""

import sys

from benchmarks import (avr_emulator, batched_world, camera_renderers, car_fit, car_profiles, fleet, fuzz_speed, gym_env, head_to_head, mac_cost, host_latency, iarrc_controller, junior_camera_rate, junior_control_latency, lane_anywhere, lanes, localization, marker_gap, planning,
                        junior_sim_speed, micropython_boards, parser_throughput, ppo_training, race_ratio, racing_line, recording, rl_transfer, ros2_bridge, sbus_decode,
                        sim_speed, start_lights,
                        sweep, udp_stream, web_latency)
from roar_sim.toolchains import sizes

BENCHMARKS = [parser_throughput, sim_speed, host_latency, avr_emulator, sizes, race_ratio, car_profiles, car_fit, racing_line, junior_sim_speed,
              junior_control_latency, junior_camera_rate, micropython_boards, sbus_decode, iarrc_controller,
              udp_stream, camera_renderers, lanes, lane_anywhere, start_lights, marker_gap, localization, planning, recording, gym_env, ppo_training, batched_world, rl_transfer, fleet, head_to_head,
              sweep, web_latency, ros2_bridge, fuzz_speed, mac_cost]


def main() -> int:
    for bench in BENCHMARKS:
        print(f"== {bench.TITLE}")
        bench.run()
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
