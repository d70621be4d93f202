// One HTTP/1.x request, read byte by byte into a fixed buffer, for a board that serves a route
// without a heap and without blocking its loop: the request line ("GET /?a=b HTTP/1.1") is
// kept, header lines are skipped except for "Connection:" and the headers that declare a body
// ("Content-Length:" other than 0, "Transfer-Encoding:"), and the request is complete at the
// blank line. The reader never reads a body: a request that declares one is complete with
// has_body(), for the board to refuse, so body bytes are never taken for a next request. A request line longer than the buffer, a request longer than
// kMaxRequestBytes in all, or a request line that is not "METHOD /target HTTP/1.x" ends the
// read with an error; the board answers it and closes the connection. After a complete request
// the connection stays open for the next one (keep_alive()) unless the client asked otherwise
// (HTTP/1.0 without "Connection: keep-alive", or "Connection: close").
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace roar {

enum class HttpRead : uint8_t {
  Incomplete = 0,  // keep feeding
  Complete = 1,    // method(), path() and query() are valid
  Malformed = 2,   // not an HTTP/1.x request line
  TooLong = 3,     // request line or whole request over its limit
};

class HttpRequestReader {
 public:
  static const uint16_t kMaxLineBytes = 256;     // [bytes] the request line, without its line end
  static const uint16_t kMaxRequestBytes = 2048;  // [bytes] request line and headers

  // Feed one byte. Once the result is not Incomplete it stays so until reset().
  HttpRead feed(uint8_t byte);
  void reset();
  HttpRead state() const { return state_; }

  // After Complete: the request line's pieces (not NUL-terminated; use the lengths).
  const char* method() const { return line_; }
  size_t method_length() const { return method_len_; }
  const char* path() const { return line_ + path_at_; }  // "/" of "/?forward=True"
  size_t path_length() const { return path_len_; }
  const char* query() const { return line_ + query_at_; }  // "forward=True", without the '?'
  size_t query_length() const { return query_len_; }
  bool keep_alive() const { return state_ == HttpRead::Complete && keep_alive_; }
  bool has_body() const { return has_body_; }  // a body follows the headers (not read)

 private:
  static const uint8_t kHeaderPrefix = 32;  // [bytes] of each header line looked at

  bool parse_line();
  void header_line_end();

  char line_[kMaxLineBytes];
  uint16_t line_len_ = 0;
  uint16_t total_ = 0;
  uint16_t method_len_ = 0, path_at_ = 0, path_len_ = 0, query_at_ = 0, query_len_ = 0;
  char header_[kHeaderPrefix];  // the current header line's start, lower case
  uint8_t header_len_ = 0;
  bool in_request_line_ = true;
  bool at_line_start_ = false;  // in the headers: nothing but CR seen on this line yet
  bool keep_alive_ = false;
  bool has_body_ = false;
  HttpRead state_ = HttpRead::Incomplete;
};

}  // namespace roar
