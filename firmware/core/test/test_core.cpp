// Native test of the firmware core: the golden vectors plus seeded random stress of the
// parser, the watchdog across the clock wrap, the reply queue, the L298N driver, the BLE byte
// queue between two threads, the HTTP request reader and the Junior's loop. Built plain, under
// -fsanitize=address,undefined and under -fsanitize=thread, and run by tests/firmware/test_sanitizers.py.
// Prints one line per failure and a closing "N passed, N failed".
#include <stdio.h>
#include <string.h>

#include <thread>

#include "roar/car_board.h"
#include "roar/car.h"
#include "roar/http_request.h"
#include "roar/iarrc.h"
#include "roar/junior_board.h"
#include "roar/junior_control.h"
#include "roar/l298n_driver.h"
#include "roar/sbus.h"
#include "roar/spsc_bytes.h"
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
      const bool values = r == ParseResult::Ok
                              ? p.command().throttle_us == e.first && p.command().steering_us == e.steering
                              : r != ParseResult::Setpoint ||
                                    (p.setpoint().speed_mm_s == e.first && p.setpoint().steering_us == e.steering);
      const Signature& sig = p.signature();
      const bool signature = (r != ParseResult::Ok && r != ParseResult::Setpoint) ||
                             (sig.present == e.is_signed && (!sig.present || (sig.counter == e.counter && sig.mac == e.mac)));
      const bool same = e.at == i && e.result == r && values && signature;
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
  uint32_t accepted = 0, injected = 0, out_of_range = 0, bad_results = 0;
  char valid[12];
  for (int i = 0; i < 2000000; ++i) {
    if (i % 97 == 0) {  // a valid message now and then: a '(' starts a new message from any state
      const unsigned t = 1000 + rng.below(1001), st = 1000 + rng.below(1001);
      snprintf(valid, sizeof(valid), "(%u,%u)", t, st);
      for (const char* c = valid; *c; ++c) accepted += p.feed(static_cast<uint8_t>(*c)) == ParseResult::Ok;
      ++injected;
      if (p.command().throttle_us != t || p.command().steering_us != st) ++out_of_range;
    }
    const uint8_t b = (i % 3) ? static_cast<uint8_t>(kAlphabet[rng.below(sizeof(kAlphabet) - 1)])
                              : static_cast<uint8_t>(rng.next());
    const ParseResult r = p.feed(b);
    if (r == ParseResult::Ok) {
      ++accepted;
      const ControlCommand c = p.command();
      if (c.throttle_us < 1000 || c.throttle_us > 2000 || c.steering_us < 1000 || c.steering_us > 2000) ++out_of_range;
    }
    if (static_cast<uint8_t>(r) >= kParseResultCount) ++bad_results;
  }
  CHECK(out_of_range == 0, "%u out-of-range commands accepted", (unsigned)out_of_range);
  CHECK(bad_results == 0, "%u results outside the enum", (unsigned)bad_results);
  CHECK(accepted >= injected && injected > 20000, "%u valid messages accepted of %u injected", (unsigned)accepted,
        (unsigned)injected);
}

static void test_failsafe_across_the_raw_clock_wrap() {
  // The board's 32-bit counter wraps 256 us after the neutral command; the core's clock does not.
  MonotonicClock clock;
  const RawMicros raw0 = 0xFFFFFF00u;
  const Micros t0 = clock.extend(raw0);
  CommandWatchdog wd(250000);
  WatchdogEvent ev;
  CHECK(wd.accept(ControlCommand{1500, 1500}, t0, &ev) && ev == WatchdogEvent::Armed, "neutral arms");
  CHECK(wd.poll(clock.extend(raw0 + 250000u)) == WatchdogEvent::None, "not at exactly the timeout");
  CHECK(wd.poll(clock.extend(raw0 + 250001u)) == WatchdogEvent::Tripped, "trips across the wrap");
  CHECK(clock.now() == t0 + 250001u, "the extended clock runs on through the wrap: %llu",
        (unsigned long long)(clock.now() - t0));
  CHECK(!wd.accept(ControlCommand{1700, 1500}, clock.extend(raw0 + 260000u), &ev), "latched ignores forward");
  CHECK(wd.accept(ControlCommand{1510, 1400}, clock.extend(raw0 + 270000u), &ev) && ev == WatchdogEvent::Armed,
        "re-arms near neutral");
}

static void test_monotonic_clock_over_many_wraps() {
  Rng rng{7};
  MonotonicClock clock;
  RawMicros raw = 0xFFFF0000u;
  Micros expected = clock.extend(raw);
  uint32_t wrong = 0;
  for (int i = 0; i < 100000; ++i) {  // steps up to 2^31 us: about 25 wraps of the raw counter
    const RawMicros step = rng.next() >> (1 + rng.below(31));
    raw += step;
    expected += step;
    if (clock.extend(raw) != expected) ++wrong;
  }
  CHECK(wrong == 0 && expected > (Micros{20} << 32), "%u wrong readings over %llu wraps", (unsigned)wrong,
        (unsigned long long)(expected >> 32));
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
  const DurationUs kDeadTime = 5000;
  L298nDriver drv(kDeadTime);
  Micros now = 0;
  int prev_dir[2] = {0, 0}, last_moving_dir[2] = {0, 0};
  Micros coast_since[2] = {0, 0};
  uint32_t over_full_scale = 0, both_high = 0, duty_coasting = 0, short_dead_times = 0, reversals = 0;
  for (int i = 0; i < 200000; ++i) {
    now += 1 + rng.below(3000);
    // duties past full scale either way too: the driver clamps them
    const SideDuties d = {static_cast<int16_t>(static_cast<int32_t>(rng.below(2401)) - 1200),
                          static_cast<int16_t>(static_cast<int32_t>(rng.below(2401)) - 1200)};
    const DrivePins p = drv.step(d, now);
    const SidePins sides[2] = {p.left, p.right};
    for (int s = 0; s < 2; ++s) {
      if (sides[s].duty > 1000) ++over_full_scale;
      const int dir = sides[s].in1 ? 1 : (sides[s].in2 ? -1 : 0);
      if (sides[s].in1 && sides[s].in2) ++both_high;
      if (dir == 0 && sides[s].duty != 0) ++duty_coasting;
      if (dir != 0 && last_moving_dir[s] == -dir) {  // this side reverses: it must have coasted long enough
        ++reversals;
        if (prev_dir[s] != 0 || now - coast_since[s] < kDeadTime) ++short_dead_times;
      }
      if (dir == 0 && prev_dir[s] != 0) coast_since[s] = now;
      if (dir != 0) last_moving_dir[s] = dir;
      prev_dir[s] = dir;
    }
  }
  CHECK(over_full_scale == 0, "%u duties over full scale", (unsigned)over_full_scale);
  CHECK(both_high == 0, "both direction pins high %u times", (unsigned)both_high);
  CHECK(duty_coasting == 0, "duty while coasting %u times", (unsigned)duty_coasting);
  CHECK(short_dead_times == 0, "%u of %u reversals without the full dead time", (unsigned)short_dead_times,
        (unsigned)reversals);
  CHECK(reversals > 1000, "only %u reversals: the run did not exercise the dead time", (unsigned)reversals);
}

// A HAL on plain variables: a serial port with a settable amount of transmit room.
struct FakeHal : Hal {
  RawMicros t = 0;
  uint32_t frames = 0;
  const char* rx = "";
  size_t room = 0;
  char tx[256] = {0};
  size_t tx_len = 0;
  uint16_t throttle = 0, steering = 0;
  uint32_t feeds = 0;
  RawMicros now_us() override { return t; }
  void feed_watchdog() override { ++feeds; }
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
  CHECK(hal.feeds == 1, "the loop feeds the watchdog once per iteration: %u", (unsigned)hal.feeds);
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
  CHECK(r.applied == 3 && r.error == JuniorQueryError::None, "applied %u", r.applied);
  SideDuties d = j.duties(2000);
  CHECK(d.left == 500 && d.right == 250, "forward %d %d", d.left, d.right);
  // A query with anything not understood is refused whole: nothing changes, the offender is named.
  const char* refused[] = {"turnLeft=True&bogus=1", "turnLeft=True&left_spd=1.5", "forward=yes",
                           "left_spd=nan", "left_spd=-0.5&forward=True", "right_spd="};
  const JuniorQueryError why[] = {JuniorQueryError::UnknownName, JuniorQueryError::BadSpeed, JuniorQueryError::BadFlag,
                                  JuniorQueryError::BadSpeed, JuniorQueryError::BadSpeed, JuniorQueryError::BadSpeed};
  for (int i = 0; i < 6; ++i) {
    r = j.apply_query(refused[i], strlen(refused[i]), 2500);
    CHECK(r.error == why[i] && r.applied == 0, "'%s' refused: %d", refused[i], static_cast<int>(r.error));
  }
  r = j.apply_query("turnLeft=True&bogus=1", 21, 2500);
  CHECK(r.bad_at == 14 && r.bad_length == 7, "names bogus=1 at %u+%u", r.bad_at, r.bad_length);
  d = j.duties(3000);
  CHECK(d.left == 500 && d.right == 250 && j.timed_out(1000 + proto::kJuniorFailsafeTimeoutUs + 1),
        "refused queries changed nothing, not even the timeout %d %d", d.left, d.right);
  const char q2[] = "turnLeft=True&forward=False&&left_spd=1";  // False: no effect; empty parts skipped
  r = j.apply_query(q2, sizeof(q2) - 1, 3000);
  CHECK(r.applied == 3 && j.duties(3000).left == -1000 && j.duties(3000).right == 250, "spin left");
  const char q3[] = "left_spd=1&right_spd=.75&backward=True";  // order: speeds first, then motion
  j.apply_query(q3, sizeof(q3) - 1, 4000);
  d = j.duties(4000);
  CHECK(d.left == -1000 && d.right == -750, "backward %d %d", d.left, d.right);
  j.apply_query("stop=True&forward=True", 22, 4000);
  CHECK(j.motion() == JuniorMotion::Forward, "in order: the last flag wins");
  j.apply_query("forward=True&stop=True", 22, 4000);
  CHECK(j.motion() == JuniorMotion::Stop, "in order: the last flag wins");
  j.apply_query("backward=True", 13, 4000);
  d = j.duties(4000 + proto::kJuniorFailsafeTimeoutUs);
  CHECK(d.left == -1000, "still driving at the timeout %d", d.left);
  d = j.duties(4001 + proto::kJuniorFailsafeTimeoutUs);
  CHECK(d.left == 0 && d.right == 0, "failsafe stops both sides %d %d", d.left, d.right);
  const char q4[] = "stop=True";
  j.apply_query(q4, sizeof(q4) - 1, 0xFFFFFF00u);
  CHECK(!j.timed_out(0x100000100u) && j.duties(0x100000100u).left == 0, "stop");
  CHECK(j.timed_out(0xFFFFFF00u + (Micros{1} << 32)), "a request 2^32 us old is stale, not fresh again");
  r = j.apply_query("", 0, 5000);
  CHECK(r.applied == 0 && r.error == JuniorQueryError::None && !j.timed_out(5000), "an empty query is a request");
  uint16_t p = 0;
  const char* good[] = {"0", "1", "0.5", ".25", "1.000", "0.1239"};
  const uint16_t want[] = {0, 1000, 500, 250, 1000, 123};
  for (int i = 0; i < 6; ++i) {
    CHECK(parse_unit_permille(good[i], strlen(good[i]), &p) && p == want[i], "%s -> %u", good[i], p);
  }
  const char* bad[] = {"", ".", "-0.5", "1.5", "2", "0.5x", "abc", "True", "nan", "1e-3"};
  for (const char* b : bad) CHECK(!parse_unit_permille(b, strlen(b), &p), "accepted '%s'", b);
  CHECK(echo_us_to_cm(5882) == 100, "1 m echo -> %lu cm", (unsigned long)echo_us_to_cm(5882));
}

// Two threads, as a BLE stack task and the main loop: every message arrives whole, in order,
// unchanged; a push that does not fit is refused whole (the producer retries it) and counted.
// TSan reports any access the ordering does not cover.
static void test_spsc_bytes_between_threads() {
  SpscBytes<16> small;  // first on one thread: a write that does not fit leaves no fragment
  const uint8_t ten[10] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  uint8_t got[16];
  CHECK(small.push(ten, 10) && !small.push(ten, 10) && small.dropped() == 1, "second write refused");
  CHECK(small.pop(got, sizeof(got)) == 10 && !memcmp(got, ten, 10), "only the first write is there");
  CHECK(small.push(ten, 10) && small.push(ten, 6) && small.pop(got, sizeof(got)) == 16, "wraps around the ring");
  static SpscBytes<64> queue;
  const uint32_t kMessages = 200000;
  uint32_t refused = 0;
  std::thread producer([&] {
    Rng rng{5};
    uint8_t msg[20];
    for (uint32_t i = 0; i <= kMessages; ++i) {  // message kMessages is the end mark: length 0
      const uint8_t n = i == kMessages ? 1 : static_cast<uint8_t>(2 + rng.below(18));
      msg[0] = i == kMessages ? 0 : n;  // length byte, then n - 1 consecutive bytes
      for (uint8_t k = 1; k < n; ++k) msg[k] = static_cast<uint8_t>(i + k);
      while (!queue.push(msg, n)) {
        ++refused;
        std::this_thread::yield();
      }
    }
  });
  uint32_t received = 0, corrupt = 0;
  uint8_t stream[64];
  size_t have = 0;
  bool done = false;
  while (!done) {
    have += queue.pop(stream + have, sizeof(stream) - have);
    size_t at = 0;
    while (at < have) {
      const uint8_t n = stream[at];
      if (n == 0) {
        done = true;
        break;
      }
      if (have - at < n) break;  // the rest of this message comes with the next pop
      for (uint8_t k = 2; k < n; ++k) {  // consecutive bytes within a message
        if (stream[at + k] != static_cast<uint8_t>(stream[at + 1] + k - 1)) ++corrupt;
      }
      ++received;
      at += n;
    }
    memmove(stream, stream + at, have - at);
    have -= at;
  }
  producer.join();
  CHECK(received == kMessages && corrupt == 0, "%u of %u messages arrived, %u corrupt", (unsigned)received,
        (unsigned)kMessages, (unsigned)corrupt);
  CHECK(refused == queue.dropped(), "dropped() counts refused writes: %u vs %u", (unsigned)queue.dropped(),
        (unsigned)refused);
}

static HttpRead read_all(HttpRequestReader& r, const char* text, size_t n) {
  HttpRead state = HttpRead::Incomplete;
  for (size_t i = 0; i < n && state == HttpRead::Incomplete; ++i) state = r.feed(static_cast<uint8_t>(text[i]));
  return state;
}

static bool same(const char* text, size_t n, const char* want) { return n == strlen(want) && !memcmp(text, want, n); }

static void test_http_request_reader() {
  HttpRequestReader r;
  const char get[] = "GET /?forward=True&left_spd=0.5 HTTP/1.1\r\nHost: 192.168.4.1:81\r\nAccept: */*\r\n\r\n";
  CHECK(read_all(r, get, sizeof(get) - 1) == HttpRead::Complete, "a browser's request completes");
  CHECK(same(r.method(), r.method_length(), "GET") && same(r.path(), r.path_length(), "/") &&
            same(r.query(), r.query_length(), "forward=True&left_spd=0.5"),
        "request line pieces");
  r.reset();
  const char bare[] = "GET /cam-lo.jpg HTTP/1.0\n\n";
  CHECK(read_all(r, bare, sizeof(bare) - 1) == HttpRead::Complete && r.query_length() == 0 &&
            same(r.path(), r.path_length(), "/cam-lo.jpg"),
        "LF line ends, no headers, no query");
  const char* malformed[] = {"GET\r\n\r\n", "GET / \r\n\r\n", "get / HTTP/1.1\r\n\r\n", "GET foo HTTP/1.1\r\n\r\n",
                             "GET / HTTP/2.0\r\n\r\n", "GET  / HTTP/1.1\r\n\r\n", "GET / HTTP/1.1 x\r\n\r\n",
                             "\r\n\r\n", "GET /a\x01 HTTP/1.1\r\n\r\n"};
  for (const char* m : malformed) {
    r.reset();
    CHECK(read_all(r, m, strlen(m)) == HttpRead::Malformed, "malformed: '%s'", m);
  }
  // Every split of a request gives the same result (the reader is fed one byte at a time anyway,
  // so feed it after garbage-free resets at every position to exercise reset()).
  for (size_t cut = 0; cut < sizeof(get) - 1; ++cut) {
    r.reset();
    HttpRead first = read_all(r, get, cut);
    HttpRead rest = read_all(r, get + cut, sizeof(get) - 1 - cut);
    CHECK(first == HttpRead::Incomplete && rest == HttpRead::Complete, "cut at %u", (unsigned)cut);
  }
  static char long_line[400];
  memcpy(long_line, "GET /?", 6);
  memset(long_line + 6, 'a', sizeof(long_line) - 6);
  r.reset();
  CHECK(read_all(r, long_line, sizeof(long_line)) == HttpRead::TooLong, "a 400-byte request line");
  static char endless[3000];
  memcpy(endless, "GET / HTTP/1.1\r\n", 16);
  for (size_t i = 16; i < sizeof(endless); ++i) endless[i] = (i % 40 == 39) ? '\n' : 'h';
  r.reset();
  CHECK(read_all(r, endless, sizeof(endless)) == HttpRead::TooLong, "endless headers end at the request limit");
  // Random bytes: the reader always decides within kMaxRequestBytes (+1), never overruns.
  Rng rng{77};
  uint32_t undecided = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    r.reset();
    HttpRead state = HttpRead::Incomplete;
    for (int i = 0; i <= HttpRequestReader::kMaxRequestBytes && state == HttpRead::Incomplete; ++i) {
      static const char kAlphabet[] = "GET / HTTP/1.1\r\n?=&ab";
      const uint8_t b = rng.below(4) ? static_cast<uint8_t>(kAlphabet[rng.below(sizeof(kAlphabet) - 1)])
                                     : static_cast<uint8_t>(rng.next());
      state = r.feed(b);
    }
    if (state == HttpRead::Incomplete) ++undecided;
  }
  CHECK(undecided == 0, "%u random requests left undecided past the limit", (unsigned)undecided);
}

struct FakeJuniorHal : JuniorHal {
  RawMicros t = 0;
  DrivePins pins = {};
  uint32_t feeds = 0;
  RawMicros now_us() override { return t; }
  void write_motors(const DrivePins& p) override { pins = p; }
  void feed_watchdog() override { ++feeds; }
};

static void test_junior_board() {
  FakeJuniorHal hal;
  JuniorBoard board(hal);
  HttpRequestReader r;
  char out[JuniorBoard::kMaxReplyBytes];
  bool keep = false;
  const char get[] = "GET /?forward=True&left_spd=0.5&right_spd=0.5 HTTP/1.1\r\n\r\n";
  read_all(r, get, sizeof(get) - 1);
  size_t n = board.respond(r, 42, out, sizeof(out), &keep);
  CHECK(n > 0 && strstr(out, "HTTP/1.1 200 OK\r\n") == out && strstr(out, "\r\nContent-Length: 2\r\n") &&
            strstr(out, "\r\nConnection: keep-alive\r\n") && !strcmp(out + n - 6, "\r\n\r\n42") && keep,
        "200 with the distance, connection kept: '%s'", out);
  board.poll();
  CHECK(hal.pins.left.in1 && hal.pins.left.duty == 500 && hal.pins.right.duty == 500 && hal.feeds == 1,
        "drives forward at half duty");
  const char* other[][2] = {{"POST / HTTP/1.1\r\n\r\n", "405"}, {"GET /x?forward=True HTTP/1.1\r\n\r\n", "404"},
                            {"GE\x01 / HTTP/1.1\r\n\r\n", "400"}, {"GET /?speed=9 HTTP/1.1\r\n\r\n", "400"},
                            {"GET /?left_spd=nan HTTP/1.1\r\n\r\n", "400"}};
  for (auto& o : other) {
    r.reset();
    read_all(r, o[0], strlen(o[0]));
    n = board.respond(r, 42, out, sizeof(out), &keep);
    CHECK(n > 0 && !strncmp(out + 9, o[1], 3) && !keep && strstr(out, "Connection: close"), "'%s' -> %s: '%s'", o[0],
          o[1], out);
  }
  CHECK(strstr(out, "\r\n\r\na speed takes a number 0..1: 'left_spd=nan'\n") != nullptr, "the reason: '%s'", out);
  board.poll();
  CHECK(hal.pins.left.duty == 500, "refused requests changed nothing: %u", hal.pins.left.duty);
  r.reset();
  read_all(r, "GET /?stop=True HTTP/1.0\r\n\r\n", 28);
  board.respond(r, 7, out, sizeof(out), &keep);
  CHECK(!keep && strstr(out, "Connection: close"), "HTTP/1.0 closes");
  r.reset();
  const char closing[] = "GET / HTTP/1.1\r\nHost: x\r\nCONNECTION: Close\r\n\r\n";
  read_all(r, closing, sizeof(closing) - 1);
  board.respond(r, 7, out, sizeof(out), &keep);
  CHECK(!keep, "Connection: close is honoured whatever its case");
  r.reset();
  const char keep10[] = "GET / HTTP/1.0\r\nConnection: keep-alive\r\n\r\n";
  read_all(r, keep10, sizeof(keep10) - 1);
  board.respond(r, 7, out, sizeof(out), &keep);
  CHECK(keep, "HTTP/1.0 with keep-alive keeps");
  CHECK(board.respond(r, 42, out, 20, &keep) == 0, "a buffer below kMaxReplyBytes gets nothing");
  // The failsafe fires in the loop while the next request is still arriving byte by byte.
  r.reset();
  read_all(r, get, sizeof(get) - 1);
  board.respond(r, 42, out, sizeof(out), &keep);
  r.reset();
  const char slow[] = "GET /?forward=True HTTP/1.1\r\nHost: x\r\n\r\n";
  hal.t = 0;
  bool stopped_mid_request = false;
  for (size_t i = 0; i < sizeof(slow) - 2; ++i) {  // all but the last line end: never complete
    r.feed(static_cast<uint8_t>(slow[i]));
    hal.t += 20000;  // one byte every 20 ms
    board.poll();
    if (hal.t > proto::kJuniorFailsafeTimeoutUs + 1000 && hal.pins.left.duty == 0 && !hal.pins.left.in1) {
      stopped_mid_request = true;
    }
  }
  CHECK(r.state() == HttpRead::Incomplete && stopped_mid_request, "motors stop while a request is in progress");
}

// SBUS: random channel values round-trip; a stream of frames cut, corrupted and mixed with
// junk never locks without three good frames in a row, and every good frame it reports is one
// that was sent whole.
static void test_sbus_random() {
  Rng rng{0x5b05u};
  int checked = 0, locked_seen = 0;
  for (int round = 0; round < 2000; ++round) {
    SbusFrame f = {};
    for (uint8_t c = 0; c < kSbusChannels; ++c) f.raw[c] = static_cast<uint16_t>(rng.below(2048));
    f.frame_lost = rng.below(4) == 0;
    f.end = static_cast<uint8_t>(rng.below(2) ? 0 : 0x04 + 0x10 * rng.below(4));
    uint8_t bytes[proto::kSbusFrameBytes];
    sbus_encode(f, bytes);
    SbusFrame back;
    const bool ok = sbus_decode(bytes, &back) && memcmp(back.raw, f.raw, sizeof(f.raw)) == 0 &&
                    back.frame_lost == f.frame_lost && back.end == f.end;
    CHECK(ok, "round trip %d", round);
    ++checked;
  }
  SbusDecoder d;
  Micros t = 0;
  uint8_t good_in_row = 0;
  for (int piece = 0; piece < 20000; ++piece) {
    SbusFrame f = {};
    for (uint8_t c = 0; c < kSbusChannels; ++c) f.raw[c] = static_cast<uint16_t>(200 + rng.below(1600));
    uint8_t bytes[proto::kSbusFrameBytes];
    sbus_encode(f, bytes);
    const uint32_t kind = rng.below(10);
    size_t n = proto::kSbusFrameBytes;
    if (kind == 0) n = 1 + rng.below(24);                                    // cut short
    if (kind == 1) bytes[1 + rng.below(23)] ^= static_cast<uint8_t>(1 + rng.below(255));  // a corrupted byte
    if (kind == 2) for (size_t i = 0; i < n; ++i) bytes[i] = static_cast<uint8_t>(rng.next());  // junk
    t += rng.below(3) == 0 ? 7000 : 120;  // sometimes the frame gap, sometimes none
    SbusResult last = SbusResult::None;
    for (size_t i = 0; i < n; ++i) {
      last = d.feed(bytes[i], t);
      t += 120;
      if (last == SbusResult::Frame) {
        good_in_row = good_in_row < 3 ? good_in_row + 1 : 3;
      } else if (last == SbusResult::Failsafe) {
        good_in_row = 0;
      }
    }
    CHECK(d.locked() == (good_in_row >= 3), "lock follows good frames in a row (piece %d)", piece);
    if (kind >= 3 && last == SbusResult::Frame) {  // a whole frame was sent and reported: it is that frame
      CHECK(memcmp(d.frame().raw, f.raw, sizeof(f.raw)) == 0, "the reported frame is the sent one (piece %d)", piece);
    }
    locked_seen += d.locked();
  }
  CHECK(checked == 2000 && locked_seen > 1000 && d.dropped() > 100 && d.good_frames() > 5000,
        "the stream exercised lock, drops and frames: locked %d, dropped %u, good %u", locked_seen,
        (unsigned)d.dropped(), (unsigned)d.good_frames());
}

// Quadrature: a shaft turning forward then back by random steps counts exactly its position;
// a jump of two states at once is a missed edge, counted as an error and not as motion.
static void test_quadrature() {
  static const uint8_t kGray[4] = {0, 2, 3, 1};  // AB states in forward order (A is bit 1)
  Rng rng{0x9e37u};
  QuadratureDecoder q;
  int32_t position = 0;
  for (int i = 0; i < 100000; ++i) {
    position += rng.below(2) ? 1 : -1;
    const uint8_t ab = kGray[((position % 4) + 4) % 4];
    q.update(ab & 2, ab & 1);
  }
  CHECK(q.count() == position && q.errors() == 0, "count %ld, position %ld, errors %lu", (long)q.count(),
        (long)position, (unsigned long)q.errors());
  const int32_t before = q.count();
  const uint8_t now = kGray[((position % 4) + 4) % 4];
  const uint8_t skipped = kGray[(((position + 2) % 4) + 4) % 4];  // two steps at once
  q.update(skipped & 2, skipped & 1);
  CHECK(q.count() == before && q.errors() == 1 && now != skipped, "a missed edge is an error, not motion");
}

int main() {
  test_vectors();
  test_parser_random_bytes();
  test_failsafe_across_the_raw_clock_wrap();
  test_monotonic_clock_over_many_wraps();
  test_replies_small_buffers();
  test_l298n_random();
  test_board_loop();
  test_junior_control();
  test_spsc_bytes_between_threads();
  test_http_request_reader();
  test_junior_board();
  test_sbus_random();
  test_quadrature();
  printf("%d passed, %d failed\n", g_passed, g_failed);
  return g_failed ? 1 : 0;
}
