/* C ABI over the firmware core and the host board (memory_boards.h), for the host build: the
 * simulator and the tests load it from Python, whose binding (hil_sim/roar_sim/core/library.py)
 * reads this very header with cffi, so the declarations below are the only place the ABI is
 * written; its Python enums are built from the enums here. Keep them plain C that cffi parses: no
 * macros other than integer #defines, no includes or conditionals outside the guards.
 *
 * Objects live in caller-provided memory of roar_*_size() bytes, aligned to 8; nothing
 * allocates. Times are Micros: microseconds on the core's 64-bit clock, which never wraps; the
 * board loop (roar_board_*) instead reads a board's wrapping 32-bit counter, as on the cars. */
#ifndef ROAR_C_API_H
#define ROAR_C_API_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define ROAR_CORE_ABI_VERSION 11

uint32_t roar_core_abi_version(void);
uint32_t roar_protocol_version(void);

/* --- codes that cross the ABI ----------------------------------------------------------------
 * Each enum is one of the core's enum classes (c_api.cpp static_asserts every value against it);
 * fields and results carry them as uint8_t. The streaming parser's and the SBUS decoder's
 * results and the IARRC controller's modes and failsafes are wire facts, in protocol/spec.toml
 * (ParseResult, SbusResult, IarrcMode, IarrcFailsafe in roar/protocol.h). */
enum roar_watchdog_event { ROAR_WATCHDOG_EVENT_NONE = 0, ROAR_WATCHDOG_EVENT_TRIPPED = 1, ROAR_WATCHDOG_EVENT_ARMED = 2 };
enum roar_brake_phase {
  ROAR_BRAKE_PHASE_NEEDS_SEQUENCE = 0,
  ROAR_BRAKE_PHASE_NEUTRAL1 = 1,
  ROAR_BRAKE_PHASE_TAP = 2,
  ROAR_BRAKE_PHASE_NEUTRAL2 = 3,
  ROAR_BRAKE_PHASE_REVERSE_READY = 4
};
enum roar_control_source { ROAR_CONTROL_SOURCE_FAILSAFE = 0, ROAR_CONTROL_SOURCE_HOST = 1, ROAR_CONTROL_SOURCE_RC = 2 };
enum roar_rc_channel { ROAR_RC_CHANNEL_THROTTLE = 0, ROAR_RC_CHANNEL_STEERING = 1 };
enum roar_http_read {
  ROAR_HTTP_READ_INCOMPLETE = 0,
  ROAR_HTTP_READ_COMPLETE = 1,
  ROAR_HTTP_READ_MALFORMED = 2,
  ROAR_HTTP_READ_TOO_LONG = 3
};
enum roar_junior_query_error {
  ROAR_JUNIOR_QUERY_ERROR_NONE = 0,
  ROAR_JUNIOR_QUERY_ERROR_UNKNOWN_NAME = 1,
  ROAR_JUNIOR_QUERY_ERROR_BAD_FLAG = 2,
  ROAR_JUNIOR_QUERY_ERROR_BAD_SPEED = 3
};
enum roar_mode_switch { ROAR_MODE_SWITCH_OFF = 0, ROAR_MODE_SWITCH_MANUAL = 1, ROAR_MODE_SWITCH_AUTONOMOUS = 2 };
enum roar_iarrc_task {
  ROAR_IARRC_TASK_RC = 0,
  ROAR_IARRC_TASK_CONTROL = 1,
  ROAR_IARRC_TASK_HOST = 2,
  ROAR_IARRC_TASK_GYRO = 3,
  ROAR_IARRC_TASK_TELEMETRY = 4,
  ROAR_IARRC_TASK_BATTERY = 5
};

/* --- streaming control-message parser ---------------------------------------------------- */
typedef struct {
  uint32_t at;         /* index of the byte in this buffer that produced the event */
  uint8_t result;      /* ParseResult code, never 0 (none) */
  uint8_t is_signed;   /* ok or setpoint: 1 when the message carried COUNTER and MAC */
  uint16_t throttle;   /* [us] valid when result is ok */
  uint16_t steering;   /* [us] valid when result is ok or setpoint */
  int16_t speed_mm_s;  /* [mm/s] valid when result is setpoint */
  uint32_t counter;    /* a signed message's COUNTER */
  uint64_t mac;        /* a signed message's MAC */
} roar_parse_event_t;

size_t roar_parser_size(void);
void roar_parser_init(void* parser);
/* Feeds one byte; returns the ParseResult code. On ok, throttle and steering receive the message. */
uint8_t roar_parser_feed(void* parser, uint8_t byte, uint16_t* throttle, uint16_t* steering);
/* Feeds n bytes; stores up to max_events events and returns how many there were in all. */
size_t roar_parser_feed_buffer(void* parser, const uint8_t* data, size_t n, roar_parse_event_t* events,
                               size_t max_events);

/* --- signed control (roar/signing.h) ------------------------------------------------------------ */
/* The MAC a signed message carries (start: '(' or '['; first: throttle [us] or speed [mm/s]). */
uint64_t roar_message_mac(const uint8_t* key, uint32_t session, uint8_t start, int16_t first, uint16_t steering,
                          uint32_t counter);
uint32_t roar_key_fingerprint(const uint8_t* key);
size_t roar_auth_size(void);
void roar_auth_init(void* auth);
void roar_auth_set_key(void* auth, const uint8_t* key, uint32_t session); /* key NULL: none */
/* The verdict on the message a parser just finished with kind (ok or setpoint): kind, or
 * unsigned, forged, replay or nokey. */
uint8_t roar_auth_check(void* auth, uint8_t kind, const void* parser);
uint32_t roar_auth_last_counter(const void* auth);

/* --- command watchdog (failsafe) ----------------------------------------------------------- */
size_t roar_watchdog_size(void);
void roar_watchdog_init(void* wd, uint32_t timeout_us);
/* Returns 1 when the command may drive the car; *event gets a roar_watchdog_event. */
int roar_watchdog_accept(void* wd, uint16_t throttle, uint16_t steering, uint64_t now_us, uint8_t* event);
uint8_t roar_watchdog_poll(void* wd, uint64_t now_us); /* a roar_watchdog_event */
int roar_watchdog_latched(const void* wd);

/* --- brake/reverse FSM --------------------------------------------------------------------- */
size_t roar_brake_size(void);
void roar_brake_init(void* fsm, uint16_t neutral_us, uint16_t tap_us, uint32_t step_us);
uint16_t roar_brake_step(void* fsm, uint16_t command_us, uint64_t now_us, uint32_t frames_started);
uint8_t roar_brake_phase(const void* fsm); /* a roar_brake_phase */

/* --- output mapping ------------------------------------------------------------------------ */
uint16_t roar_map_pulse(uint16_t command_us, int16_t trim_us, uint16_t min_us, uint16_t max_us);
int roar_calibration_valid(int16_t trim_us, uint16_t min_us, uint16_t max_us);

/* --- RC override --------------------------------------------------------------------------- */
size_t roar_rc_size(void);
void roar_rc_init(void* rc);
void roar_rc_pulse(void* rc, uint8_t channel, uint16_t width_us, uint64_t now_us); /* a roar_rc_channel */
int roar_rc_active(const void* rc, uint64_t now_us);
void roar_rc_command(const void* rc, uint16_t* throttle, uint16_t* steering);

/* --- L298N and the Junior's HTTP control ------------------------------------------------------ */
typedef struct {
  uint8_t in1, in2; /* direction pins */
  uint16_t duty;    /* [permille] */
} roar_side_pins_t;

size_t roar_l298n_size(void);
void roar_l298n_init(void* drv, uint32_t dead_time_us);
void roar_l298n_step(void* drv, int16_t left, int16_t right, uint64_t now_us, roar_side_pins_t* left_out,
                     roar_side_pins_t* right_out);

size_t roar_junior_size(void);
void roar_junior_init(void* junior);
/* Applies a query string (without '?'): the parameters applied, or -(a roar_junior_query_error)
 * when the query was refused (nothing changed). */
int roar_junior_apply_query(void* junior, const char* query, size_t n, uint64_t now_us);
/* Signed per-side duties [permille] to drive now; both 0 when stopped or timed out. */
void roar_junior_duties(const void* junior, uint64_t now_us, int16_t* left, int16_t* right);

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
  uint8_t source;      /* a roar_control_source */
  uint8_t brake_phase; /* a roar_brake_phase */
  uint8_t latched;
  uint8_t reserved;
} roar_car_outputs_t;

void roar_car_default_config(roar_car_config_t* config);
size_t roar_car_size(void);
/* Returns 0, or -1 when a channel calibration is invalid (the car is then not initialised). */
int roar_car_init(void* car, const roar_car_config_t* config);
void roar_car_boot(void* car);
void roar_car_feed(void* car, const uint8_t* data, size_t n, uint64_t now_us); /* serial bytes */
void roar_car_rc_pulse(void* car, uint8_t channel, uint16_t width_us, uint64_t now_us);
void roar_car_step(void* car, uint64_t now_us, uint32_t frames_started, roar_car_outputs_t* out);
size_t roar_car_take_reply(void* car, char* buf, size_t cap);

/* --- the board loop (CarBoard::poll) on a HAL of plain memory ----------------------------------
 * What a board's peripherals would do, as fields the caller fills and reads between calls of
 * roar_board_run: no callbacks. Each loop iteration of roar_board_run:
 *   1. if now_us has reached next_frame_us, an output frame starts: frames_started counts it,
 *      the pending pulses go on the wire, and the RC receiver's pulses (rc_us, 0 = none) arrive;
 *   2. CarBoard::poll(): at most 64 bytes from rx, one Car step, pending pulses written, whole
 *      reply lines appended to tx while they fit, the hardware watchdog fed;
 *   3. now_us advances by loop_us (wrapping at 2^32, like micros()). */
#define ROAR_HOST_RX_BYTES 256
#define ROAR_HOST_TX_BYTES 256
/* the board's non-volatile memory (EEPROM): key and session */
#define ROAR_HOST_NVM_BYTES 32

typedef struct {
  uint32_t now_us;                  /* in: [us] the board's free-running 32-bit counter */
  uint32_t loop_us;                 /* in: [us] step of now_us after each loop iteration */
  uint32_t frame_us;                /* in: [us] output frame period (> 0) */
  uint32_t next_frame_us;           /* in/out: [us] start of the next output frame on now_us */
  uint32_t frames_started;          /* out: output frames begun */
  uint32_t watchdog_feeds;          /* out: times the loop fed the hardware watchdog */
  uint16_t pending_us[2];           /* out: [us] throttle, steering last written by the loop */
  uint16_t wire_us[2];              /* out: [us] throttle, steering in the current frame */
  uint16_t rc_us[2];                /* in: [us] RC receiver pulses at each frame start, 0 = none */
  uint16_t rx_len;                  /* in: bytes waiting in rx */
  uint16_t rx_pos;                  /* out: how many of them the loop has read */
  uint16_t tx_len;                  /* out: reply bytes in tx (the caller empties it) */
  uint16_t nvm_writes;              /* out: bytes written to nvm that changed (wear) */
  roar_car_outputs_t outputs;       /* out: the car's outputs in the last loop iteration */
  uint8_t rx[ROAR_HOST_RX_BYTES];   /* in: received serial bytes */
  char tx[ROAR_HOST_TX_BYTES];      /* out: reply lines written by the loop */
  uint8_t nvm[ROAR_HOST_NVM_BYTES]; /* in/out: kept by the caller across reboots (0xFF: blank) */
} roar_host_hal_t;

size_t roar_board_size(void);
/* The board keeps a pointer to hal. Returns 0, or -1 for an invalid calibration. */
int roar_board_init(void* board, roar_host_hal_t* hal, const roar_car_config_t* config);
void roar_board_begin(void* board);  /* queues the boot banner; reads nvm (key, next session) */
void roar_board_feed(void* board, const uint8_t* data, size_t n);   /* bytes of a BLE write */
void roar_board_run(void* board, uint32_t loops);
uint32_t roar_board_session(const void* board); /* the signing session; 0 when the car has no key */
uint32_t roar_board_last_counter(const void* board); /* the last counter the car accepted in it */

/* --- many ESC cars' board loops at once (the batched simulator, roar_sim.batch) ------------------
 * n boards side by side, board i at boards + i * roar_board_size() on hals[i], each initialised
 * by roar_board_init and begun. roar_boards_run, for each car whose run[i] is not 0 (run NULL:
 * every car): when throttle_us[i] is not 0, the control message (throttle_us[i], steering_us[i])
 * arrives on its serial port as a host writes it (0: the host is silent this time); then its board
 * runs `loops` loop iterations, and the pulses on its wire after iteration k go to
 * wire_us[(k * n + i) * 2 + c] (c: 0 throttle, 1 steering). Reply lines are dropped. The very
 * loop roar_board_run runs, one car after another; a car not run keeps its time and its rows. */
void roar_boards_run(void* boards, roar_host_hal_t* hals, size_t n, const uint8_t* run, const uint16_t* throttle_us,
                     const uint16_t* steering_us, uint32_t loops, uint16_t* wire_us);

/* --- the Junior's loop (JuniorBoard) and its HTTP requests, on a HAL of plain memory -----------
 * roar_junior_board_run: each loop iteration runs JuniorBoard::poll() (failsafe, L298N pins with
 * dead time, watchdog fed) and then advances now_us by loop_us. A server feeds each
 * connection's bytes to a roar_http_reader and asks the board to respond to each decided
 * request; the reply reports distance_cm. */
typedef struct {
  uint32_t now_us;              /* in: [us] the board's free-running 32-bit counter */
  uint32_t loop_us;             /* in: [us] step of now_us after each loop iteration */
  uint32_t distance_cm;         /* in: [cm] the ultrasonic reading replies report */
  uint32_t watchdog_feeds;      /* out */
  roar_side_pins_t left, right; /* out: the L298N inputs after the last loop iteration */
  uint16_t rx_len, rx_pos;      /* in / out: bytes waiting in rx (its USB serial port), and read */
  uint16_t tx_len, nvm_writes;  /* out: reply bytes in tx (the caller empties it); nvm bytes changed */
  uint8_t rx[ROAR_HOST_RX_BYTES];   /* in: received serial bytes (key lines) */
  char tx[ROAR_HOST_TX_BYTES];      /* out: lines the board wrote */
  uint8_t nvm[ROAR_HOST_NVM_BYTES]; /* in/out: kept by the caller across reboots (0xFF: blank) */
} roar_junior_hal_t;

size_t roar_junior_board_size(void);
void roar_junior_board_init(void* board, roar_junior_hal_t* hal);   /* keeps the pointer */
void roar_junior_board_begin(void* board);  /* reads nvm (key, next session) */
uint32_t roar_junior_board_session(const void* board); /* the signing session; 0 without a key */
void roar_junior_board_run(void* board, uint32_t loops);
/* The response to a decided request (its reader's state is not incomplete), NUL-terminated;
 * returns its length. *keep_open: 1 when the connection stays open for the next request. */
size_t roar_junior_board_respond(void* board, const void* reader, char* out, size_t cap, uint8_t* keep_open);
size_t roar_junior_reply_max(void);

size_t roar_http_reader_size(void);
void roar_http_reader_init(void* reader);   /* also: ready for the next request */
/* Feeds bytes until the request is decided; returns how many it took (the rest belongs to the
 * next request). *state: a roar_http_read. */
size_t roar_http_reader_feed(void* reader, const uint8_t* data, size_t n, uint8_t* state);
/* After a complete read: the request's path ("/cam-lo.jpg" of "/cam-lo.jpg?x=1"), *length bytes,
 * not NUL-terminated, valid until the reader is fed or reset. */
const char* roar_http_reader_path(const void* reader, size_t* length);
/* JuniorBoard::refuse: the response (NUL-terminated) with which every port of the Junior refuses a
 * decided request (malformed, too long, not GET, a GET with a body); 0 for a GET its routes answer. */
size_t roar_http_refuse(const void* reader, char* out, size_t cap);

/* --- SBUS receiver frames ------------------------------------------------------------------ */
typedef struct {
  uint16_t raw[16];    /* 11-bit channel values */
  uint8_t ch17, ch18;  /* digital channels */
  uint8_t frame_lost;  /* the receiver skipped a frame */
  uint8_t failsafe;    /* the receiver's failsafe flag */
  uint8_t end;         /* 0x00, or an SBUS2 slot byte */
  uint8_t reserved[3];
} roar_sbus_frame_t;

typedef struct {
  uint8_t locked;      /* kSbusLockFrames good frames in a row, no failsafe since */
  uint8_t reserved[3];
  uint32_t good_frames, lost_frames, failsafe_frames, dropped;
  uint64_t last_good_us;
} roar_sbus_status_t;

void roar_sbus_encode(const roar_sbus_frame_t* frame, uint8_t* out); /* 25 bytes */
int roar_sbus_decode(const uint8_t* in, roar_sbus_frame_t* frame);    /* 1: a well-formed frame */
size_t roar_sbus_decoder_size(void);
void roar_sbus_decoder_init(void* decoder);
/* One byte with the time it arrived; returns an SbusResult code (protocol/spec.toml sbus_result). */
uint8_t roar_sbus_feed(void* decoder, uint8_t byte, uint64_t now_us);
void roar_sbus_last_frame(const void* decoder, roar_sbus_frame_t* frame);
void roar_sbus_status(const void* decoder, roar_sbus_status_t* status);

/* --- SipHash-2-4, the MAC of the signed control mode (roar/siphash.h) ------------------------ */
/* The 64-bit MAC of n bytes under a 16-byte key, the bytes fed one at a time as a parser would. */
uint64_t roar_siphash24(const uint8_t* key, const uint8_t* data, size_t n);

/* --- the IARRC car's controller (IarrcController, default configuration) ------------------- */
typedef struct {
  uint16_t throttle_us, steering_us; /* the pulses to output now */
  uint8_t mode;                      /* an IarrcMode code (protocol/spec.toml iarrc_mode) */
  uint8_t failsafe;                  /* an IarrcFailsafe code (protocol/spec.toml iarrc_failsafe) */
  uint8_t rc_present, mode_switch;   /* mode_switch: a roar_mode_switch */
  int32_t speed_mm_s;                /* [mm/s] from the encoder */
  int32_t setpoint_mm_s;             /* [mm/s] the host's latest */
  int64_t distance_mm;               /* [mm] driven since boot */
  uint32_t battery_mv;               /* [mV] */
  uint8_t battery_low, battery_cutoff;
  uint8_t reserved[2];
  int32_t pid_integral_mm;           /* [mm] */
} roar_iarrc_status_t;

size_t roar_iarrc_size(void);
void roar_iarrc_init(void* controller);
/* Gains in per mille: [us per m/s], [us per m], [us per m/s^2], [us per m/s] (feed-forward). */
void roar_iarrc_set_pid(void* controller, int32_t kp_pm, int32_t ki_pm, int32_t kd_pm, int32_t ff_pm);
void roar_iarrc_sbus_byte(void* controller, uint8_t byte, uint64_t now_us);
uint8_t roar_iarrc_host_byte(void* controller, uint8_t byte, uint64_t now_us); /* a ParseResult code */
void roar_iarrc_encoder(void* controller, int32_t count, uint64_t now_us);
void roar_iarrc_battery(void* controller, uint16_t adc_counts);
void roar_iarrc_control(void* controller, uint64_t now_us, uint32_t frames_started, roar_iarrc_status_t* out);

/* --- the IARRC car's tasks (IarrcBoard) on a HAL of plain memory ---------------------------
 * The caller is the scheduler: it fills the inputs and calls roar_iarrc_board_run for each
 * release of a task. Received bytes wait in rx buffers (*_len bytes, *_pos of them read);
 * written lines are appended to the tx buffers (the caller empties them; what does not fit is
 * dropped, as on a full UART). */
#define ROAR_IARRC_SBUS_BYTES 128
#define ROAR_IARRC_RX_BYTES 256
#define ROAR_IARRC_TX_BYTES 512

typedef struct {
  const char* name;
  uint32_t period_us;   /* [us] */
  uint8_t priority;     /* higher pre-empts lower */
  uint8_t reserved;
  uint16_t stack_words; /* [32-bit words] */
  uint32_t cost_us;     /* [us] declared worst case on the STM32F745 at 16 MHz */
} roar_task_spec_t;

/* Two sectors of flash (roar/flash_log.h: the IARRC car keeps its key in them) as a chip's
 * behave: programming only clears bits, and a word programmed twice is refused and counted; an
 * erase sets a sector's bytes to 0xFF. power_words >= 0: the power fails once that many more
 * words are programmed (every later program or erase fails); -1: it never does. */
#define ROAR_FLASH_SECTOR_BYTES 2048
typedef struct {
  int32_t power_words;                                /* in */
  uint32_t words_programmed, erases, double_programs; /* out */
  uint8_t bytes[2 * ROAR_FLASH_SECTOR_BYTES]; /* in/out: kept by the caller across reboots (0xFF: blank) */
} roar_flash_t;

typedef struct {
  uint32_t now_us;          /* in: [us] the board's free-running 32-bit counter */
  uint32_t frames_started;  /* in: output frames begun */
  int32_t encoder_count;    /* in: wheel encoder (x4, signed) */
  uint16_t battery_adc;     /* in: [ADC counts] */
  int16_t gyro_z_raw;       /* in: MPU6000 GYRO_ZOUT, +-2000 deg/s full scale */
  uint16_t throttle_us, steering_us; /* out: [us] pulses last written */
  uint32_t watchdog_feeds;  /* out */
  uint16_t sbus_len, sbus_pos, host_len, host_pos, link_len, link_pos; /* in/out */
  uint16_t host_tx_len, link_tx_len; /* out */
  roar_flash_t flash;                 /* in/out: the sector with the key and session (a FlashLog) */
  uint32_t sbus_at_us[ROAR_IARRC_SBUS_BYTES]; /* in: now_us when each SBUS byte arrived */
  uint8_t sbus[ROAR_IARRC_SBUS_BYTES];        /* in: received SBUS bytes */
  uint8_t host_rx[ROAR_IARRC_RX_BYTES];       /* in: bytes from the vision computer */
  uint8_t link_rx[ROAR_IARRC_RX_BYTES];       /* in: bytes from the Bluetooth module */
  char host_tx[ROAR_IARRC_TX_BYTES];          /* out: lines to the vision computer */
  char link_tx[ROAR_IARRC_TX_BYTES];          /* out: lines to the Bluetooth module */
} roar_iarrc_hal_t;

uint8_t roar_iarrc_task_count(void);
void roar_iarrc_task(uint8_t index, roar_task_spec_t* out);
size_t roar_iarrc_board_size(void);
/* counts_per_m: the wheel encoder's counts per metre (0 = the default, a 66 mm wheel). */
void roar_iarrc_board_init(void* board, roar_iarrc_hal_t* hal, uint32_t counts_per_m);
void roar_iarrc_board_begin(void* board);             /* the flash log's boot (may erase); READY 2; the key */
uint32_t roar_iarrc_board_session(const void* board); /* the signing session; 0 without a key */
void roar_iarrc_board_run(void* board, uint8_t task); /* one release of a task (a roar_iarrc_task) */
void roar_iarrc_board_overran(void* board, uint8_t task, uint32_t missed);
void roar_iarrc_board_set_pid(void* board, int32_t kp_pm, int32_t ki_pm, int32_t kd_pm, int32_t ff_pm);
void roar_iarrc_board_status(const void* board, roar_iarrc_status_t* out);
uint32_t roar_iarrc_board_overruns(const void* board);

#ifdef __cplusplus
}
#endif

#endif /* ROAR_C_API_H */
