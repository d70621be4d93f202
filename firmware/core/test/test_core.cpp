// Native test of the firmware core: the golden vectors plus seeded random stress of the
// parser, the watchdog across the clock wrap, the reply queue and the L298N driver, meant to run under -fsanitize=address,undefined. Built and run by
// tests/test_native_core.py. Prints one line per failure and a closing "N passed, N failed".
#include <stdio.h>
#include <string.h>

#include "roar/board.h"
#include "roar/car.h"
#include "roar/junior_control.h"
#include "roar/l298n_mixer.h"
#include "vectors.h"

using namespace roar;

static int g_passed = 0;
static int g_failed = 0;

#define CHECK(cond, ...)                                       \
  do {                                                         \
    if (cond) {                                                \
      ++g_passed;                                              \
    } else {                                                   \
      ++g_failed;                                              \
      printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);   \
      printf(__VA_ARGS__);                                     \
      printf("\n");                                            \
    }                                                          \
  } while (0)

// xorshift32: deterministic, seedable.
struct Rng {
  uint32_t s;
  uint32_t next() {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    return s;
  }
  uint32_t below(uint32_t n) { return next() % n; }
};

static void test_vectors() {
  for (size_t c = 0; c < roar_vectors::kCaseCount; ++c) {
    const roar_vectors::Case& tc = roar_vectors::kCases[c];
    ControlParser p;
    size_t seen = 0;
    bool ok = true;
    for (size_t i = 0; i < tc.length; ++i) {
      const ParseResult r = p.feed(static_cast<uint8_t>(tc.input[i]));
      if (r == ParseResult::None) continue;
      if (seen >= tc.n_events) {
        ok = false;
        printf("FAIL vector %s: unexpected %s at %u\n", tc.name, parse_result_token(r), (unsigned)i);
        break;
      }
      const roar_vectors::Event& e = tc.events[seen++];
      const bool same = e.at == i && e.result == r &&
                        (r != ParseResult::Ok ||
                         (p.command().throttle_us == e.throttle && p.command().steering_us == e.steering));
      if (!same) {
        ok = false;
        printf("FAIL vector %s: got %s at %u, want %s at %u\n", tc.name, parse_result_token(r), (unsigned)i,
               parse_result_token(e.result), (unsigned)e.at);
      }
    }
    if (seen != tc.n_events) {
      ok = false;
      printf("FAIL vector %s: %u events, want %u\n", tc.name, (unsigned)seen, (unsigned)tc.n_events);
    }
    ok ? ++g_passed : ++g_failed;
  }
}

static void test_parser_random_bytes() {
  Rng rng{12345};
  static const char kAlphabet[] = "()0123456789,,,\n\r \x00x\xff";
  ControlParser p;
  for (int i = 0; i < 2000000; ++i) {
    const uint8_t b = (i % 3) ? static_cast<uint8_t>(kAlphabet[rng.below(sizeof(kAlphabet) - 1)])
                              : static_cast<uint8_t>(rng.next());
    const ParseResult r = p.feed(b);
    if (r == ParseResult::Ok) {
      const ControlCommand c = p.command();
      if (c.throttle_us < 1000 || c.throttle_us > 2000 || c.steering_us < 1000 || c.steering_us > 2000) {
        CHECK(false, "out-of-range command %u,%u accepted", c.throttle_us, c.steering_us);
        return;
      }
    }
    if (static_cast<uint8_t>(r) >= kParseResultCount) {
      CHECK(false, "bad result %u", static_cast<unsigned>(r));
      return;
    }
  }
  CHECK(true, "ok");
}

static void test_failsafe_wraps() {
  CommandWatchdog wd(250000);
  WatchdogEvent ev;
  const uint32_t t0 = 0xFFFFFF00u;  // 256 us before the counter wraps
  CHECK(wd.accept(ControlCommand{1500, 1500}, t0, &ev) && ev == WatchdogEvent::Armed, "neutral arms");
  CHECK(wd.poll(t0 + 250000u) == WatchdogEvent::None, "not at exactly the timeout");
  CHECK(wd.poll(t0 + 250001u) == WatchdogEvent::Tripped, "trips across the wrap");
  CHECK(!wd.accept(ControlCommand{1700, 1500}, t0 + 260000u, &ev), "latched ignores forward");
  CHECK(wd.accept(ControlCommand{1510, 1400}, t0 + 270000u, &ev) && ev == WatchdogEvent::Armed, "re-arms near neutral");
}

static void test_replies_small_buffers() {
  Car car;
  car.boot();
  char buf[64];
  CHECK(car.take_reply(buf, 3) == 0, "too small keeps the line");
  CHECK(car.take_reply(buf, sizeof(buf)) == 8 && strcmp(buf, "READY 1\n") == 0, "banner '%s'", buf);
  for (int i = 0; i < 20; ++i) car.feed('x', 0), car.feed('\n', 0);
  CHECK(car.replies_dropped() == 12, "queue of 8, dropped %u", (unsigned)car.replies_dropped());
  CHECK(car.take_reply(buf, sizeof(buf)) == 12 && strcmp(buf, "ERR garbage\n") == 0, "error line '%s'", buf);
}

static void test_l298n_random() {
  Rng rng{99};
  L298nDriver drv(5000);
  uint32_t now = 0;
  int last_dir[2] = {0, 0};
  for (int i = 0; i < 200000; ++i) {
    now += 1 + rng.below(3000);
    const SideDuties d = mix_ackermann(static_cast<uint16_t>(900 + rng.below(1200)), static_cast<uint16_t>(900 + rng.below(1200)));
    if (d.left > 1000 || d.left < -1000 || d.right > 1000 || d.right < -1000) {
      CHECK(false, "mix out of range %d %d", d.left, d.right);
      return;
    }
    const DrivePins p = drv.step(d, now);
    const SidePins sides[2] = {p.left, p.right};
    for (int s = 0; s < 2; ++s) {
      const int dir = sides[s].in1 ? 1 : (sides[s].in2 ? -1 : 0);
      if (sides[s].in1 && sides[s].in2) {
        CHECK(false, "both direction pins high");
        return;
      }
      if (dir == 0 && sides[s].duty != 0) {
        CHECK(false, "duty while coasting");
        return;
      }
      if (dir != 0 && last_dir[s] == -dir) {
        CHECK(false, "direct reversal without dead time");
        return;
      }
      last_dir[s] = dir;
    }
  }
  CHECK(true, "ok");
}

// A HAL on plain variables: a serial port with a settable amount of transmit room.
struct FakeHal : Hal {
  Micros t = 0;
  uint32_t frames = 0;
  const char* rx = "";
  size_t room = 0;
  char tx[256] = {0};
  size_t tx_len = 0;
  uint16_t throttle = 0, steering = 0;
  Micros now_us() override { return t; }
  void write_pulses(uint16_t th, uint16_t st) override { throttle = th, steering = st; }
  uint32_t frames_started() override { return frames; }
  int read_byte() override { return *rx ? static_cast<uint8_t>(*rx++) : -1; }
  size_t write_room() override { return room; }
  void write(const char* text, size_t n) override {
    CHECK(n <= room && tx_len + n < sizeof(tx), "wrote %u bytes with room %u", (unsigned)n, (unsigned)room);
    memcpy(tx + tx_len, text, n);
    tx_len += n;
    room -= n;
  }
};

static void test_board_loop() {
  FakeHal hal;
  CarBoard board(hal);
  board.begin();
  hal.rx = "(1500,1500)(1600,1400)";
  board.poll();
  CHECK(hal.tx_len == 0, "no room, nothing written (%u bytes)", (unsigned)hal.tx_len);
  CHECK(hal.throttle == 1600 && hal.steering == 1400, "pulses %u %u", hal.throttle, hal.steering);
  hal.room = 30;  // room for one whole line only
  hal.t = 1000;
  board.poll();
  CHECK(strcmp(hal.tx, "READY 1\n") == 0, "first line only: '%s'", hal.tx);
  hal.room = 200;
  board.poll();
  CHECK(strcmp(hal.tx, "READY 1\nARMED\n") == 0, "then the rest: '%s'", hal.tx);
  // A flood is taken at most kMaxBytesPerPoll bytes per loop.
  static char flood[400];
  memset(flood, 'x', sizeof(flood) - 1);
  hal.rx = flood;
  board.poll();
  CHECK(strlen(hal.rx) == sizeof(flood) - 1 - CarBoard::kMaxBytesPerPoll, "left %u", (unsigned)strlen(hal.rx));
  const uint8_t ble[] = "(1700,1500)";
  board.feed(ble, sizeof(ble) - 1);
  hal.rx = "";
  hal.t = 2000;
  board.poll();
  CHECK(hal.throttle == 1700, "BLE bytes drive too: %u", hal.throttle);
}

static void test_junior_control() {
  JuniorControl j;
  CHECK(j.duties(0).left == 0 && j.timed_out(0), "stopped before any request");
  const char q1[] = "forward=True&left_spd=0.5&right_spd=0.25";
  JuniorQueryResult r = j.apply_query(q1, sizeof(q1) - 1, 1000);
  CHECK(r.applied == 3 && r.ignored == 0, "applied %u ignored %u", r.applied, r.ignored);
  SideDuties d = j.duties(2000);
  CHECK(d.left == 500 && d.right == 250, "forward %d %d", d.left, d.right);
  const char q2[] = "turnLeft=True&bogus=1&left_spd=1.5&forward=False";
  r = j.apply_query(q2, sizeof(q2) - 1, 3000);
  CHECK(r.applied == 1 && r.ignored == 3, "applied %u ignored %u", r.applied, r.ignored);
  d = j.duties(3000);
  CHECK(d.left == -500 && d.right == 250, "spin left %d %d", d.left, d.right);
  const char q3[] = "left_spd=1&right_spd=.75&backward=True";  // order: speeds first, then motion
  j.apply_query(q3, sizeof(q3) - 1, 4000);
  d = j.duties(4000);
  CHECK(d.left == -1000 && d.right == -750, "backward %d %d", d.left, d.right);
  d = j.duties(4000 + proto::kJuniorFailsafeTimeoutUs);
  CHECK(d.left == -1000, "still driving at the timeout %d", d.left);
  d = j.duties(4001 + proto::kJuniorFailsafeTimeoutUs);
  CHECK(d.left == 0 && d.right == 0, "failsafe stops both sides %d %d", d.left, d.right);
  const char q4[] = "stop=True";
  j.apply_query(q4, sizeof(q4) - 1, 0xFFFFFF00u);  // across the clock wrap
  CHECK(!j.timed_out(0x100u) && j.duties(0x100u).left == 0, "stop");
  uint16_t p = 0;
  const char* good[] = {"0", "1", "0.5", ".25", "1.000", "0.1239"};
  const uint16_t want[] = {0, 1000, 500, 250, 1000, 123};
  for (int i = 0; i < 6; ++i) {
    CHECK(parse_unit_permille(good[i], strlen(good[i]), &p) && p == want[i], "%s -> %u", good[i], p);
  }
  const char* bad[] = {"", ".", "-0.5", "1.5", "2", "0.5x", "abc", "True"};
  for (const char* b : bad) CHECK(!parse_unit_permille(b, strlen(b), &p), "accepted '%s'", b);
  CHECK(echo_us_to_cm(5882) == 100, "1 m echo -> %lu cm", (unsigned long)echo_us_to_cm(5882));
}

int main() {
  test_vectors();
  test_parser_random_bytes();
  test_failsafe_wraps();
  test_replies_small_buffers();
  test_l298n_random();
  test_board_loop();
  test_junior_control();
  printf("%d passed, %d failed\n", g_passed, g_failed);
  return g_failed ? 1 : 0;
}
