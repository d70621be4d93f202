"""The batched world: many ESC cars stepped together for learning at batched speed, the firmware
core's board loop in the batch (in C), a single-track body identified from the PyBullet car, a
lidar marched on each track's distance field (docs/gym.md: when to use it, how closely it matches).

    boards       the core's board loops for n cars through one C call (roar_boards_run)
    track_pool   the tracks the cars share: distance fields and centre lines
    kernels      the compiled loops: ESC, servo, latency, body, contact, lidar, progress
    model        a car's numbers: its profile's and the identified physics (Physics)
    world        BatchWorld: n cars, reset and stepped together
    camera       every car's camera: rays cast on the floor's paint and the walls
    identify     Physics fitted to the PyBullet car by least squares
    fidelity     how closely the batched car and the PyBullet car agree
"""
