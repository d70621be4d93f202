#include "roar/signing.h"

#include "roar/siphash.h"

namespace roar {

namespace {

const uint8_t kMagic0 = 'R', kMagic1 = 'K';
const uint8_t kFlagKeyed = 1;
const uint8_t kZeroKey[kSipKeyBytes] = {};

void put_le(uint8_t* out, uint32_t v, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>(v >> (8 * i));
}

bool is_line_end(uint8_t b) { return b == '\r' || b == '\n'; }

int8_t hex_value(uint8_t b) {
  if (static_cast<uint8_t>(b - '0') <= 9) return static_cast<int8_t>(b - '0');
  if (static_cast<uint8_t>(b - 'a') <= 5) return static_cast<int8_t>(b - 'a' + 10);
  if (static_cast<uint8_t>(b - 'A') <= 5) return static_cast<int8_t>(b - 'A' + 10);
  return -1;
}

}  // namespace

uint64_t message_mac(const uint8_t key[proto::kSignedKeyBytes], uint32_t session, uint8_t start, int16_t first,
                     uint16_t steering, uint32_t counter) {
  uint8_t m[proto::kSignedMacInputBytes];
  put_le(m, session, 4);
  m[4] = start;
  put_le(m + 5, static_cast<uint16_t>(first), 2);
  put_le(m + 7, steering, 2);
  put_le(m + 9, counter, 4);
  const uint64_t mask = (static_cast<uint64_t>(1) << proto::kSignedMacBits) - 1;
  return SipHash24::mac(key, m, sizeof(m)) & mask;
}

uint32_t key_fingerprint(const uint8_t key[proto::kSignedKeyBytes]) {
  static const uint8_t kName[4] = {'R', 'O', 'A', 'R'};
  return static_cast<uint32_t>(SipHash24::mac(key, kName, sizeof(kName)));
}

void Authenticator::set_key(const uint8_t* key, uint32_t session) {
  keyed_ = key != nullptr;
  for (uint8_t i = 0; i < proto::kSignedKeyBytes; ++i) key_[i] = keyed_ ? key[i] : 0;
  session_ = keyed_ ? session : 0u;
  last_counter_ = 0;
}

ParseResult Authenticator::check(ParseResult kind, const ControlParser& parser) {
  const Signature& sig = parser.signature();
  if (!keyed_) return sig.present ? ParseResult::Nokey : kind;
  if (!sig.present) return ParseResult::Unsigned;
  const bool setpoint = kind == ParseResult::Setpoint;
  const int16_t first = setpoint ? parser.setpoint().speed_mm_s : static_cast<int16_t>(parser.command().throttle_us);
  const uint16_t steering = setpoint ? parser.setpoint().steering_us : parser.command().steering_us;
  const uint8_t start = setpoint ? proto::kSetpointStartChar : proto::kControlStartChar;
  // The MAC first: a forged message must not learn whether its counter would have passed.
  if (message_mac(key_, session_, start, first, steering, sig.counter) != sig.mac) return ParseResult::Forged;
  if (sig.counter <= last_counter_) return ParseResult::Replay;
  last_counter_ = sig.counter;
  return kind;
}

KeyRecord KeyRecord::load(Nvm& nvm) {
  uint8_t b[kBytes];
  nvm.read(0, b, kBytes);
  KeyRecord r;
  const uint16_t check = static_cast<uint16_t>(SipHash24::mac(kZeroKey, b, kBytes - 2));
  if (b[0] != kMagic0 || b[1] != kMagic1 || b[kBytes - 2] != static_cast<uint8_t>(check) ||
      b[kBytes - 1] != static_cast<uint8_t>(check >> 8)) {
    return r;  // blank or damaged: no key
  }
  r.keyed = (b[2] & kFlagKeyed) != 0;
  for (uint8_t i = 0; i < proto::kSignedKeyBytes; ++i) r.key[i] = b[3 + i];
  const uint8_t* s = b + 3 + proto::kSignedKeyBytes;
  r.session = s[0] | static_cast<uint32_t>(s[1]) << 8 | static_cast<uint32_t>(s[2]) << 16 | static_cast<uint32_t>(s[3]) << 24;
  return r;
}

void KeyRecord::store(Nvm& nvm) const {
  uint8_t b[kBytes];
  b[0] = kMagic0;
  b[1] = kMagic1;
  b[2] = keyed ? kFlagKeyed : 0;
  for (uint8_t i = 0; i < proto::kSignedKeyBytes; ++i) b[3 + i] = keyed ? key[i] : 0;
  put_le(b + 3 + proto::kSignedKeyBytes, session, 4);
  const uint16_t check = static_cast<uint16_t>(SipHash24::mac(kZeroKey, b, kBytes - 2));
  put_le(b + kBytes - 2, check, 2);
  nvm.write(0, b, kBytes);
}

void start_session(Nvm* nvm, Authenticator& auth) {
  if (nvm == nullptr) return;
  KeyRecord r = KeyRecord::load(*nvm);
  if (!r.keyed) {
    auth.set_key(nullptr, 0);
    return;
  }
  ++r.session;
  if (r.session == 0) r.session = 1;  // after 2^32 boots; 0 means "no key" on the wire
  r.store(*nvm);  // before use: a session is never drawn twice
  auth.set_key(r.key, r.session);
}

KeyLine::Event KeyLine::feed(uint8_t byte) {
  static const char kWord[] = "KEY ";
  const bool end = is_line_end(byte);
  switch (state_) {
    case State::LineStart:
      if (byte == kWord[0]) {
        state_ = State::Word;
        at_ = 1;
        return Event::Taken;
      }
      if (!end && byte != proto::kControlEndChar && byte != proto::kSetpointEndChar) state_ = State::Other;
      return Event::NotMine;
    case State::Other:  // a key line may begin after a line end or a message's end
      if (end || byte == proto::kControlEndChar || byte == proto::kSetpointEndChar) state_ = State::LineStart;
      return Event::NotMine;
    case State::Word:
      if (byte == static_cast<uint8_t>(kWord[at_])) {
        ++at_;
        if (at_ == sizeof(kWord) - 1) {
          state_ = State::Hex;
          at_ = 0;
        }
        return Event::Taken;
      }
      break;
    case State::Hex:
      if (at_ == 0 && byte == '-') {
        state_ = State::Clear;
        return Event::Taken;
      }
      if (at_ == 0 && byte == '?') {
        state_ = State::Ask;
        return Event::Taken;
      }
      if (hex_value(byte) >= 0 && at_ < 2 * proto::kSignedKeyBytes) {
        const uint8_t v = static_cast<uint8_t>(hex_value(byte));
        key_[at_ / 2] = static_cast<uint8_t>(at_ % 2 == 0 ? v << 4 : (key_[at_ / 2] | v));
        ++at_;
        return Event::Taken;
      }
      if (end && at_ == 2 * proto::kSignedKeyBytes) {
        state_ = State::LineStart;
        return Event::Set;
      }
      break;
    case State::Clear:
    case State::Ask:
      if (end) {
        const Event ev = state_ == State::Clear ? Event::Clear : Event::Ask;
        state_ = State::LineStart;
        return ev;
      }
      break;
  }
  state_ = end ? State::LineStart : State::Other;
  return Event::Bad;
}

}  // namespace roar
