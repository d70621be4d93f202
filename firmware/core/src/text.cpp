#include "roar/text.h"

namespace roar {

bool append(char* buf, size_t cap, size_t* len, const char* text) {
  for (; *text; ++text) {
    if (*len + 1 >= cap) return false;
    buf[(*len)++] = *text;
  }
  if (*len < cap) buf[*len] = '\0';
  return true;
}

bool append_uint(char* buf, size_t cap, size_t* len, uint32_t value) {
  char digits[11];  // 4294967295 and the NUL
  uint8_t n = sizeof(digits) - 1;
  digits[n] = '\0';
  do {
    digits[--n] = static_cast<char>('0' + value % 10u);
    value /= 10u;
  } while (value);
  return append(buf, cap, len, digits + n);
}

bool append_hex(char* buf, size_t cap, size_t* len, uint32_t value, uint8_t min_digits) {
  char digits[9];  // ffffffff and the NUL
  uint8_t n = sizeof(digits) - 1;
  digits[n] = '\0';
  do {
    digits[--n] = "0123456789abcdef"[value & 0xFu];
    value >>= 4;
  } while (n > 0 && (value || sizeof(digits) - 1 - n < min_digits));
  return append(buf, cap, len, digits + n);
}

bool append_int(char* buf, size_t cap, size_t* len, int32_t value) {
  if (value >= 0) return append_uint(buf, cap, len, static_cast<uint32_t>(value));
  // -2147483648 has no positive int32_t: negate in unsigned arithmetic
  return append(buf, cap, len, "-") && append_uint(buf, cap, len, 0u - static_cast<uint32_t>(value));
}

bool equals(const char* text, size_t length, const char* word) {
  size_t i = 0;
  for (; i < length; ++i) {
    if (word[i] == '\0' || text[i] != word[i]) return false;
  }
  return word[i] == '\0';
}

}  // namespace roar
