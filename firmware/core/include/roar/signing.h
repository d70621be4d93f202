// Signed control (protocol/spec.toml [signed]): only the holder of the car's key drives it.
//
//   Authenticator  the verdict on each message the parser accepted: a car without a key takes
//                  unsigned messages (and refuses signed ones: nokey); a car with a key takes only
//                  signed ones whose MAC its key and session give and whose counter is above the
//                  last it took (unsigned, forged, replay otherwise). A refused message changes
//                  nothing: it neither drives nor feeds the failsafe.
//   KeyRecord      the key and the session counter in the board's non-volatile memory (Nvm, a
//                  few bytes of EEPROM, NVS or flash behind the board's HAL). Each boot with a key
//                  draws the next session and stores it before using it, so no session (and no
//                  message signed in one) is ever valid twice, across any number of reboots.
//   KeyLine        the serial-only command line "KEY <32 hex>" / "KEY -" / "KEY ?" (at the start
//                  of a line or right after a message), read as it arrives (no line buffer): the
//                  only way a key is set or cleared.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/control_parser.h"
#include "roar/protocol.h"

namespace roar {

// A few bytes of non-volatile memory, from address 0 of the area the board gives the core.
class Nvm {
 public:
  virtual void read(uint16_t at, uint8_t* data, uint8_t n) = 0;
  virtual void write(uint16_t at, const uint8_t* data, uint8_t n) = 0;  // only bytes that change need a write

 protected:
  ~Nvm() = default;
};

// The MAC a signed message carries: the low kSignedMacBits bits of SipHash-2-4 under key over
// session, start character, first field, steering and counter (kSignedMacInputBytes bytes).
uint64_t message_mac(const uint8_t key[proto::kSignedKeyBytes], uint32_t session, uint8_t start, int16_t first,
                     uint16_t steering, uint32_t counter);
// The key's name: the low 32 bits of SipHash-2-4 under the key of "ROAR".
uint32_t key_fingerprint(const uint8_t key[proto::kSignedKeyBytes]);
// The MAC a signed HTTP query carries (the Junior): the low kSignedMacBits bits of SipHash-2-4
// under key over the session (uint32 LE) and the query's text before "&mac=".
uint64_t query_mac(const uint8_t key[proto::kSignedKeyBytes], uint32_t session, const char* text, size_t n);

class Authenticator {
 public:
  // Use this key (nullptr: none) from a new session on; the counter starts again.
  void set_key(const uint8_t* key, uint32_t session);

  // The verdict on a message the parser finished with Ok or Setpoint (passed as `kind`): `kind`
  // when it may act, else Unsigned, Forged, Replay or Nokey.
  ParseResult check(ParseResult kind, const ControlParser& parser);

  // The verdict on an HTTP query (the Junior's): signed, it ends "ctr=HEX&mac=HEX12" (the two
  // last parameters, lowercase hex as in a message). Ok when it may act, with *apply_length the
  // length of the query before its "&ctr=" (the parameters to apply); else Unsigned, Forged,
  // Replay, Nokey, or Syntax for a malformed ctr or mac.
  ParseResult check_query(const char* query, size_t length, size_t* apply_length);

  bool keyed() const { return keyed_; }
  uint32_t session() const { return session_; }
  uint32_t last_counter() const { return last_counter_; }
  uint32_t fingerprint() const { return keyed_ ? key_fingerprint(key_) : 0u; }

 private:
  ParseResult accept(ParseResult kind, uint32_t counter, uint64_t mac, uint64_t expected);

  uint8_t key_[proto::kSignedKeyBytes] = {};
  bool keyed_ = false;
  uint32_t session_ = 0;
  uint32_t last_counter_ = 0;  // the last counter accepted in this session (0: none yet)
};

// The record in Nvm: magic "RK", flags (bit 0: a key is set), the key, the last session
// (uint32 LE), and a check (16 bits of SipHash-2-4 under a zero key over the bytes before it).
struct KeyRecord {
  static const uint8_t kBytes = 2 + 1 + proto::kSignedKeyBytes + 4 + 2;  // [bytes] of Nvm used

  bool keyed = false;
  uint8_t key[proto::kSignedKeyBytes] = {};
  uint32_t session = 0;  // the last session drawn (0: never)

  // The stored record, or none (blank or damaged memory: no key, no session yet).
  static KeyRecord load(Nvm& nvm);
  void store(Nvm& nvm) const;
};

// Non-volatile memory a board reads whole at boot and writes whole (a flash sector, an NVS blob):
// the board fills cache() at boot (0xFF where blank) and gives persist().
class CachedNvm : public Nvm {
 public:
  static const uint8_t kBytes = (KeyRecord::kBytes + 3) / 4 * 4;  // [bytes] whole 32-bit words, as flash takes them
  void read(uint16_t at, uint8_t* data, uint8_t n) override;
  void write(uint16_t at, const uint8_t* data, uint8_t n) override;  // the cache, then persist()
  uint8_t* cache() { return bytes_; }

 protected:
  virtual void persist(const uint8_t* data, uint8_t n) = 0;
  ~CachedNvm() = default;

 private:
  uint8_t bytes_[kBytes] = {};
};

// Boot: the key in nvm (if any) with a fresh session, stored before it is used.
void start_session(Nvm* nvm, Authenticator& auth);

// "KEY ..." on the serial link. feed() takes a byte and says what became of it.
class KeyLine {
 public:
  enum class Event : uint8_t {
    NotMine,   // not a key line: the byte goes to the control parser
    Taken,     // part of a key line
    Set,       // "KEY <32 hex>" ended: key() holds the new key
    Clear,     // "KEY -" ended
    Ask,       // "KEY ?" ended
    Bad,       // a line that began "K" but is not a key command (answered ERR syntax); this
               // byte goes to the control parser too, so stray bytes never hold control back
  };
  // Inlined for the common byte (inside a line that is not a key line), which every serial
  // byte of a control message is: one test.
  __attribute__((always_inline)) Event feed(uint8_t byte) {
    if (state_ == State::Other && byte != proto::kControlEndChar && byte != proto::kSetpointEndChar && byte != '\n' &&
        byte != '\r') {
      return Event::NotMine;
    }
    return feed_slow(byte);
  }
  const uint8_t* key() const { return key_; }

 private:
  Event feed_slow(uint8_t byte);
  enum class State : uint8_t { LineStart, Other, Word, Hex, Clear, Ask };
  State state_ = State::LineStart;
  uint8_t at_ = 0;  // characters of "KEY " matched, then hex digits taken
  uint8_t key_[proto::kSignedKeyBytes] = {};
};

// A board's key: kept in its Nvm, changed only by key lines from its serial link. Every board
// (the ESC car, the Junior, the IARRC car) holds one and answers the same way.
class KeyStore {
 public:
  enum class Answer : uint8_t {
    None,       // nothing to say
    Key,        // "KEY <fingerprint>" or "KEY none" (then "SESSION ..." when keyed and the key changed)
    NoStorage,  // "ERR nokey": the board has nowhere to keep a key (or could not keep this one)
    Syntax,     // "ERR syntax": a line that began "K" but is not a key command
  };
  void boot(Nvm* nvm) {
    nvm_ = nvm;
    start_session(nvm, auth_);
  }
  Answer on_key_line(KeyLine::Event ev, const uint8_t* key);
  // The same, answered as text for a board that writes its serial lines at once (the Junior, the
  // IARRC car): "KEY ..." (and "SESSION ..." after a change), or "ERR nokey" / "ERR syntax";
  // returns the length written into out (0: nothing to say). cap: 2 reply lines and a NUL.
  size_t on_key_line(KeyLine::Event ev, const uint8_t* key, char* out, size_t cap);
  Authenticator& auth() { return auth_; }
  const Authenticator& auth() const { return auth_; }

 private:
  Nvm* nvm_ = nullptr;
  Authenticator auth_;
};

// What a refusal's words carry after the token: the session (unsigned, forged), the last
// counter (replay), else 0 (nothing). Taken when the message is refused.
uint32_t refusal_value(ParseResult verdict, const Authenticator& auth);
// The reason's token and, for unsigned / forged / replay, that value in hex ("forged 0000002a"):
// what every board says after "ERR " (or in the Junior's 403 body).
bool append_refusal(char* buf, size_t cap, size_t* len, ParseResult verdict, uint32_t value);

// "KEY <fingerprint>" or "KEY none", and "SESSION <8 hex>", each with the line end.
bool append_key_reply(char* buf, size_t cap, size_t* len, const Authenticator& auth);
bool append_session_reply(char* buf, size_t cap, size_t* len, const Authenticator& auth);

}  // namespace roar
