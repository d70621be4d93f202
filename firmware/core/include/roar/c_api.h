/* C ABI over the firmware core, for the host build (Python loads it with ctypes: the simulator
 * and the tests use it). Objects live in caller-provided memory of roar_*_size() bytes,
 * aligned to 8; nothing allocates. Times are the wrapping 32-bit microsecond clock. */
#ifndef ROAR_C_API_H
#define ROAR_C_API_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define ROAR_CORE_ABI_VERSION 1u

uint32_t roar_core_abi_version(void);
uint32_t roar_protocol_version(void);

/* --- streaming control-message parser ---------------------------------------------------- */
typedef struct {
  uint32_t at;        /* index of the byte in this buffer that produced the event */
  uint8_t result;     /* ParseResult code, never 0 (none) */
  uint8_t reserved;
  uint16_t throttle;  /* [us] valid when result is ok */
  uint16_t steering;  /* [us] valid when result is ok */
} roar_parse_event_t;

size_t roar_parser_size(void);
void roar_parser_init(void* parser);
/* Feeds one byte; returns the ParseResult code. On ok, throttle and steering receive the message. */
uint8_t roar_parser_feed(void* parser, uint8_t byte, uint16_t* throttle, uint16_t* steering);
/* Feeds n bytes; stores up to max_events events and returns how many there were in all. */
size_t roar_parser_feed_buffer(void* parser, const uint8_t* data, size_t n, roar_parse_event_t* events,
                               size_t max_events);

/* --- command watchdog (failsafe) ----------------------------------------------------------- */
size_t roar_watchdog_size(void);
void roar_watchdog_init(void* wd, uint32_t timeout_us);
/* Returns 1 when the command may drive the car; *event gets 0 none, 1 tripped, 2 armed. */
int roar_watchdog_accept(void* wd, uint16_t throttle, uint16_t steering, uint32_t now_us, uint8_t* event);
uint8_t roar_watchdog_poll(void* wd, uint32_t now_us);
int roar_watchdog_latched(const void* wd);

/* --- brake/reverse FSM --------------------------------------------------------------------- */
size_t roar_brake_size(void);
void roar_brake_init(void* fsm, uint16_t neutral_us, uint16_t tap_us, uint32_t step_us);
uint16_t roar_brake_step(void* fsm, uint16_t command_us, uint32_t now_us, uint32_t frames_started);
uint8_t roar_brake_phase(const void* fsm);

/* --- output mapping ------------------------------------------------------------------------ */
uint16_t roar_map_pulse(uint16_t command_us, int16_t trim_us, uint16_t min_us, uint16_t max_us);
int roar_calibration_valid(int16_t trim_us, uint16_t min_us, uint16_t max_us);

/* --- RC override --------------------------------------------------------------------------- */
size_t roar_rc_size(void);
void roar_rc_init(void* rc);
void roar_rc_pulse(void* rc, uint8_t channel, uint16_t width_us, uint32_t now_us); /* 0 throttle, 1 steering */
int roar_rc_active(const void* rc, uint32_t now_us);
void roar_rc_command(const void* rc, uint16_t* throttle, uint16_t* steering);

/* --- L298N ----------------------------------------------------------------------------------- */
typedef struct {
  uint8_t in1, in2; /* direction pins */
  uint16_t duty;    /* [permille] */
} roar_side_pins_t;

void roar_mix_ackermann(uint16_t throttle_us, uint16_t steering_us, int16_t* left, int16_t* right);
size_t roar_l298n_size(void);
void roar_l298n_init(void* drv, uint32_t dead_time_us);
void roar_l298n_step(void* drv, int16_t left, int16_t right, uint32_t now_us, roar_side_pins_t* left_out,
                     roar_side_pins_t* right_out);

/* --- the whole car --------------------------------------------------------------------------- */
typedef struct {
  uint32_t failsafe_timeout_us;
  uint32_t brake_step_us;
  uint16_t brake_tap_us;
  int16_t throttle_trim_us;
  uint16_t throttle_min_us;
  uint16_t throttle_max_us;
  int16_t steering_trim_us;
  uint16_t steering_min_us;
  uint16_t steering_max_us;
  uint8_t failsafe_enabled;
  uint8_t brake_fsm_enabled;
  uint8_t rc_override_enabled;
  uint8_t reserved[3];
} roar_car_config_t;

typedef struct {
  uint16_t throttle_us;
  uint16_t steering_us;
  uint8_t source;      /* 0 failsafe, 1 host, 2 rc */
  uint8_t brake_phase; /* BrakePhase */
  uint8_t latched;
  uint8_t reserved;
} roar_car_outputs_t;

size_t roar_car_config_size(void);
void roar_car_default_config(roar_car_config_t* config);
size_t roar_car_size(void);
/* Returns 0, or -1 when a channel calibration is invalid (the car is then not initialised). */
int roar_car_init(void* car, const roar_car_config_t* config);
void roar_car_boot(void* car);
void roar_car_feed(void* car, const uint8_t* data, size_t n, uint32_t now_us);
void roar_car_rc_pulse(void* car, uint8_t channel, uint16_t width_us, uint32_t now_us);
void roar_car_step(void* car, uint32_t now_us, uint32_t frames_started, roar_car_outputs_t* out);
size_t roar_car_take_reply(void* car, char* buf, size_t cap);

#ifdef __cplusplus
}
#endif

#endif /* ROAR_C_API_H */
