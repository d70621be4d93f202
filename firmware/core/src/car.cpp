#include "roar/car.h"

#include "roar/text.h"

namespace roar {

Car::Car(const CarConfig& config)
    : config_(config),
      watchdog_(config.failsafe_timeout_us),
      brake_(config.brake),
      host_command_(neutral_command()) {}

void Car::boot(Nvm* nvm) {
  keys_.boot(nvm);
  queue(Reply::Ready);
  if (keys_.auth().keyed()) queue(Reply::Session);
}

void Car::queue(Reply kind, ParseResult detail, uint32_t value) {
  if (reply_count_ == kQueue) {
    ++replies_dropped_;
    return;
  }
  replies_[(reply_head_ + reply_count_) % kQueue] = QueuedReply{kind, detail, value};
  ++reply_count_;
}

void Car::on_watchdog(WatchdogEvent ev) {
  if (ev == WatchdogEvent::Tripped && !latch_notified_) {
    queue(Reply::Failsafe);
    latch_notified_ = true;
  } else if (ev == WatchdogEvent::Armed) {
    queue(Reply::Armed);
    latch_notified_ = false;
  }
}

void Car::feed(const uint8_t* data, size_t n, Micros now_us, Link link) {
  for (size_t i = 0; i < n; ++i) {
    const uint8_t byte = data[i];
    if (link == Link::Serial) {
      const KeyLine::Event ev = key_line_.feed(byte);
      if (ev != KeyLine::Event::NotMine) {
        on_key_line(ev);
        if (ev != KeyLine::Event::Bad) continue;
      }
    }
    const ParseResult r = parser_.feed(byte);
    if (r != ParseResult::None) on_message(r, now_us);
  }
}

void Car::on_key_line(KeyLine::Event ev) {
  const bool changes = ev == KeyLine::Event::Set || ev == KeyLine::Event::Clear;
  switch (keys_.on_key_line(ev, key_line_.key())) {
    case KeyStore::Answer::Key:
      queue(Reply::Key);
      if (changes && keys_.auth().keyed()) queue(Reply::Session);
      return;
    case KeyStore::Answer::NoStorage:
      queue(Reply::Error, ParseResult::Nokey);
      return;
    case KeyStore::Answer::Syntax:
      queue(Reply::Error, ParseResult::Syntax);
      return;
    case KeyStore::Answer::None:
      return;
  }
}

void Car::on_message(ParseResult r, Micros now_us) {
  if (r == ParseResult::Ok || r == ParseResult::Setpoint) {
    const ParseResult verdict = keys_.auth().check(r, parser_);
    if (verdict != r) {  // refused: nothing changes, the failsafe is not fed
      queue(Reply::Error, verdict, refusal_value(verdict, keys_.auth()));
      return;
    }
  }
  if (r == ParseResult::Setpoint) {  // a valid message, but this car drives by throttle, not speed
    queue(Reply::Unsupported);
    return;
  }
  if (r != ParseResult::Ok) {
    queue(Reply::Error, r);
    return;
  }
  if (!config_.failsafe_enabled) {
    host_command_ = parser_.command();
    return;
  }
  WatchdogEvent ev = WatchdogEvent::None;
  if (watchdog_.accept(parser_.command(), now_us, &ev)) {
    host_command_ = parser_.command();
  } else if (!latch_notified_) {  // ignored while latched: say why, once
    queue(Reply::Failsafe);
    latch_notified_ = true;
  }
  on_watchdog(ev);
}

CarOutputs Car::step(Micros now_us, uint32_t frames_started) {
  ControlSource source = ControlSource::Host;
  if (config_.failsafe_enabled) {
    on_watchdog(watchdog_.poll(now_us));
    if (watchdog_.latched()) source = ControlSource::Failsafe;
  }
  if (config_.rc_override_enabled && rc_.active(now_us)) source = ControlSource::Rc;

  ControlCommand cmd = source == ControlSource::Host ? host_command_
                       : source == ControlSource::Rc ? rc_.command()
                                                     : neutral_command();
  if (config_.brake_fsm_enabled) cmd.throttle_us = brake_.step(cmd.throttle_us, now_us, frames_started);
  return CarOutputs{map_pulse(cmd.throttle_us, config_.throttle), map_pulse(cmd.steering_us, config_.steering),
                    source, brake_.phase()};
}

size_t Car::take_reply(char* buf, size_t cap) {
  if (reply_count_ == 0 || cap == 0) return 0;
  const QueuedReply& q = replies_[reply_head_];
  size_t len = 0;
  buf[0] = '\0';
  bool ok = true;
  switch (q.kind) {
    case Reply::Ready:
      ok = append(buf, cap, &len, proto::kSerialReplyReady) && append(buf, cap, &len, " ") &&
           append_uint(buf, cap, &len, proto::kMetaProtocolVersion);
      break;
    case Reply::Error:
      ok = append(buf, cap, &len, proto::kSerialReplyError) && append(buf, cap, &len, " ") &&
           append_refusal(buf, cap, &len, q.detail, q.value);
      break;
    case Reply::Session:  // (these two are as they are when taken, with their line end)
      ok = append_session_reply(buf, cap, &len, keys_.auth());
      break;
    case Reply::Key:
      ok = append_key_reply(buf, cap, &len, keys_.auth());
      break;
    case Reply::Failsafe:
      ok = append(buf, cap, &len, proto::kSerialReplyFailsafe);
      break;
    case Reply::Armed:
      ok = append(buf, cap, &len, proto::kSerialReplyArmed);
      break;
    case Reply::Unsupported:
      ok = append(buf, cap, &len, proto::kSerialReplyError) && append(buf, cap, &len, " ") &&
           append(buf, cap, &len, proto::kSerialErrorUnsupported);
      break;
  }
  const bool ended = q.kind == Reply::Session || q.kind == Reply::Key;
  if (!ok || (!ended && !append(buf, cap, &len, proto::kSerialReplyLineEnd))) {
    buf[0] = '\0';
    return 0;
  }
  reply_head_ = static_cast<uint8_t>((reply_head_ + 1) % kQueue);
  --reply_count_;
  return len;
}

}  // namespace roar
