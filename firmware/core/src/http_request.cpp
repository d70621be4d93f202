#include "roar/http_request.h"

namespace roar {
namespace {

bool is_token_char(char c) { return c >= 'A' && c <= 'Z'; }  // methods: GET, POST, ...
bool is_target_char(char c) { return c > ' ' && c < 0x7F; }  // visible ASCII, no spaces
bool starts_with(const char* text, size_t length, const char* prefix) {
  size_t i = 0;
  for (; prefix[i]; ++i) {
    if (i >= length || text[i] != prefix[i]) return false;
  }
  return true;
}

bool contains(const char* text, size_t length, const char* word) {
  for (size_t i = 0; i < length; ++i) {
    if (starts_with(text + i, length - i, word)) return true;
  }
  return false;
}

char lower(uint8_t b) { return static_cast<char>(b >= 'A' && b <= 'Z' ? b + ('a' - 'A') : b); }

}  // namespace

void HttpRequestReader::reset() {
  line_len_ = total_ = 0;
  method_len_ = path_at_ = path_len_ = query_at_ = query_len_ = 0;
  header_len_ = 0;
  in_request_line_ = true;
  at_line_start_ = false;
  keep_alive_ = false;
  has_body_ = false;
  state_ = HttpRead::Incomplete;
}

void HttpRequestReader::header_line_end() {
  static const char kConnection[] = "connection:";
  static const char kContentLength[] = "content-length:";
  if (starts_with(header_, header_len_, kConnection)) {
    const char* value = header_ + sizeof(kConnection) - 1;
    const size_t value_len = header_len_ - (sizeof(kConnection) - 1);
    if (contains(value, value_len, "close")) keep_alive_ = false;
    if (contains(value, value_len, "keep-alive")) keep_alive_ = true;
  } else if (starts_with(header_, header_len_, kContentLength)) {
    // a body unless the value is all zeros (and spaces); a value cut off by the prefix counts
    if (header_len_ == kHeaderPrefix) has_body_ = true;
    for (size_t i = sizeof(kContentLength) - 1; i < header_len_; ++i) {
      if (header_[i] != '0' && header_[i] != ' ' && header_[i] != '\t') has_body_ = true;
    }
  } else if (starts_with(header_, header_len_, "transfer-encoding:")) {
    has_body_ = true;
  }
  header_len_ = 0;
}

HttpRead HttpRequestReader::feed(uint8_t byte) {
  if (state_ != HttpRead::Incomplete) return state_;
  if (++total_ > kMaxRequestBytes) return state_ = HttpRead::TooLong;
  if (byte == '\r') return state_;  // line ends are "\r\n" or "\n"
  if (in_request_line_) {
    if (byte == '\n') {
      if (!parse_line()) return state_ = HttpRead::Malformed;
      in_request_line_ = false;
      at_line_start_ = true;
      return state_;
    }
    if (line_len_ == kMaxLineBytes) return state_ = HttpRead::TooLong;
    line_[line_len_++] = static_cast<char>(byte);
    return state_;
  }
  if (byte == '\n') {
    if (at_line_start_) return state_ = HttpRead::Complete;  // the blank line ends the headers
    header_line_end();
    at_line_start_ = true;
  } else {
    at_line_start_ = false;
    if (header_len_ < kHeaderPrefix) header_[header_len_++] = lower(byte);
  }
  return state_;
}

// "METHOD SP /target SP HTTP/1.x"
bool HttpRequestReader::parse_line() {
  size_t i = 0;
  while (i < line_len_ && is_token_char(line_[i])) ++i;
  if (i == 0 || i >= line_len_ || line_[i] != ' ') return false;
  method_len_ = static_cast<uint16_t>(i);
  const size_t target = ++i;
  while (i < line_len_ && is_target_char(line_[i])) ++i;
  if (i == target || line_[target] != '/' || i >= line_len_ || line_[i] != ' ') return false;
  const size_t target_end = i++;
  if (!starts_with(line_ + i, line_len_ - i, "HTTP/1.") || line_len_ - i != 8) return false;
  keep_alive_ = line_[i + 7] != '0';  // HTTP/1.1 keeps the connection by default, 1.0 does not
  size_t q = target;
  while (q < target_end && line_[q] != '?') ++q;
  path_at_ = static_cast<uint16_t>(target);
  path_len_ = static_cast<uint16_t>(q - target);
  query_at_ = static_cast<uint16_t>(q < target_end ? q + 1 : target_end);
  query_len_ = static_cast<uint16_t>(target_end - query_at_);
  return true;
}

}  // namespace roar
