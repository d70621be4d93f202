#include "roar/signing.h"

#include "roar/siphash.h"
#include "roar/text.h"

namespace roar {

namespace {

const uint8_t kMagic0 = 'R', kMagic1 = 'K';
const uint8_t kFlagKeyed = 1;
const uint8_t kZeroKey[kSipKeyBytes] = {};

void put_le(uint8_t* out, uint32_t v, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>(v >> (8 * i));
}

bool is_line_end(uint8_t b) { return b == '\r' || b == '\n'; }

int8_t hex_value(uint8_t b) {  // (a key line also takes uppercase)
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

uint64_t query_mac(const uint8_t key[proto::kSignedKeyBytes], uint32_t session, const char* text, size_t n) {
  SipHash24 h;
  h.begin(key);
  for (uint8_t i = 0; i < 4; ++i) h.add(static_cast<uint8_t>(session >> (8 * i)));
  for (size_t i = 0; i < n; ++i) h.add(static_cast<uint8_t>(text[i]));
  return h.finish() & ((static_cast<uint64_t>(1) << proto::kSignedMacBits) - 1);
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
  return accept(kind, sig.counter, sig.mac, message_mac(key_, session_, start, first, steering, sig.counter));
}

ParseResult Authenticator::accept(ParseResult kind, uint32_t counter, uint64_t mac, uint64_t expected) {
  // The MAC first: a forged message must not learn whether its counter would have passed.
  if (mac != expected) return ParseResult::Forged;
  if (counter <= last_counter_) return ParseResult::Replay;
  last_counter_ = counter;
  return kind;
}

namespace {
// Lowercase hex of digits 1..max_digits; false for anything else.
bool parse_hex(const char* text, size_t n, uint8_t max_digits, uint64_t* value) {
  if (n == 0 || n > max_digits) return false;
  uint64_t v = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t b = static_cast<uint8_t>(text[i]);
    if (static_cast<uint8_t>(b - 'A') <= 5) return false;  // lowercase only, as in a message
    const int8_t h = hex_value(b);
    if (h < 0) return false;
    v = (v << 4) | static_cast<uint8_t>(h);
  }
  *value = v;
  return true;
}

// The start of the last parameter of text[0..n) ('&' excluded), i.e. after its last '&', or 0.
size_t last_param(const char* text, size_t n) {
  size_t at = n;
  while (at > 0 && text[at - 1] != '&') --at;
  return at;
}

bool starts_with(const char* text, size_t n, const char* word) {
  size_t i = 0;
  for (; word[i]; ++i) {
    if (i >= n || text[i] != word[i]) return false;
  }
  return true;
}
}  // namespace

ParseResult Authenticator::check_query(const char* query, size_t length, size_t* apply_length) {
  *apply_length = length;
  const size_t mac_at = last_param(query, length);
  if (!starts_with(query + mac_at, length - mac_at, "mac=")) return keyed_ ? ParseResult::Unsigned : ParseResult::Ok;
  if (!keyed_) return ParseResult::Nokey;
  if (mac_at == 0) return ParseResult::Syntax;  // no ctr before it
  const size_t signed_length = mac_at - 1;      // the text before "&mac="
  const size_t ctr_at = last_param(query, signed_length);
  uint64_t mac = 0, counter = 0;
  if (!starts_with(query + ctr_at, signed_length - ctr_at, "ctr=") ||
      !parse_hex(query + ctr_at + 4, signed_length - ctr_at - 4, proto::kSignedCounterDigits, &counter) ||
      length - mac_at - 4 != proto::kSignedMacDigits ||
      !parse_hex(query + mac_at + 4, length - mac_at - 4, proto::kSignedMacDigits, &mac)) {
    return ParseResult::Syntax;
  }
  *apply_length = ctr_at == 0 ? 0 : ctr_at - 1;
  return accept(ParseResult::Ok, static_cast<uint32_t>(counter), mac, query_mac(key_, session_, query, signed_length));
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

void CachedNvm::read(uint16_t at, uint8_t* data, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) data[i] = at + i < kBytes ? bytes_[at + i] : 0xFF;
}

void CachedNvm::write(uint16_t at, const uint8_t* data, uint8_t n) {
  for (uint8_t i = 0; i < n && at + i < kBytes; ++i) bytes_[at + i] = data[i];
  persist(bytes_, kBytes);
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

KeyStore::Answer KeyStore::on_key_line(KeyLine::Event ev, const uint8_t* key) {
  switch (ev) {
    case KeyLine::Event::Set:
    case KeyLine::Event::Clear: {
      if (nvm_ == nullptr) return Answer::NoStorage;  // nowhere to keep a key: refuse rather than forget it
      KeyRecord record = KeyRecord::load(*nvm_);
      record.keyed = ev == KeyLine::Event::Set;
      for (uint8_t i = 0; i < proto::kSignedKeyBytes; ++i) record.key[i] = record.keyed ? key[i] : 0;
      if (++record.session == 0) record.session = 1;  // a new key starts a new session
      record.store(*nvm_);
      const KeyRecord kept = KeyRecord::load(*nvm_);  // read back: storage that is full or failing refuses
      if (kept.keyed != record.keyed || kept.session != record.session) return Answer::NoStorage;
      auth_.set_key(record.keyed ? record.key : nullptr, record.session);
      return Answer::Key;
    }
    case KeyLine::Event::Ask:
      return Answer::Key;
    case KeyLine::Event::Bad:
      return Answer::Syntax;
    default:
      return Answer::None;
  }
}

size_t KeyStore::on_key_line(KeyLine::Event ev, const uint8_t* key, char* out, size_t cap) {
  const Answer answer = on_key_line(ev, key);
  size_t n = 0;
  if (answer == Answer::Key) {
    append_key_reply(out, cap, &n, auth_);
    if ((ev == KeyLine::Event::Set || ev == KeyLine::Event::Clear) && auth_.keyed()) {
      append_session_reply(out, cap, &n, auth_);
    }
  } else if (answer != Answer::None) {
    append(out, cap, &n, proto::kSerialReplyError);
    append(out, cap, &n, " ");
    append(out, cap, &n, parse_result_token(answer == Answer::NoStorage ? ParseResult::Nokey : ParseResult::Syntax));
    append(out, cap, &n, proto::kSerialReplyLineEnd);
  }
  return n;
}

uint32_t refusal_value(ParseResult verdict, const Authenticator& auth) {
  if (verdict == ParseResult::Replay) return auth.last_counter();
  return verdict == ParseResult::Unsigned || verdict == ParseResult::Forged ? auth.session() : 0u;
}

bool append_refusal(char* buf, size_t cap, size_t* len, ParseResult verdict, uint32_t value) {
  if (!append(buf, cap, len, parse_result_token(verdict))) return false;
  if (verdict == ParseResult::Unsigned || verdict == ParseResult::Forged) {
    return append(buf, cap, len, " ") && append_hex(buf, cap, len, value, proto::kSignedSessionDigits);
  }
  if (verdict == ParseResult::Replay) return append(buf, cap, len, " ") && append_hex(buf, cap, len, value, 1);
  return true;
}

bool append_key_reply(char* buf, size_t cap, size_t* len, const Authenticator& auth) {
  return append(buf, cap, len, proto::kSignedKeyCommand) && append(buf, cap, len, " ") &&
         (auth.keyed() ? append_hex(buf, cap, len, auth.fingerprint(), proto::kSignedFingerprintDigits)
                       : append(buf, cap, len, proto::kSignedKeyNone)) &&
         append(buf, cap, len, proto::kSerialReplyLineEnd);
}

bool append_session_reply(char* buf, size_t cap, size_t* len, const Authenticator& auth) {
  return append(buf, cap, len, proto::kSignedReplySession) && append(buf, cap, len, " ") &&
         append_hex(buf, cap, len, auth.session(), proto::kSignedSessionDigits) &&
         append(buf, cap, len, proto::kSerialReplyLineEnd);
}

KeyLine::Event KeyLine::feed_slow(uint8_t byte) {
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
