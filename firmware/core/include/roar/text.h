// Short texts without printf or heap, for the core's serial and HTTP replies and its HTTP
// parsing. append*() add at *len and keep the text NUL-terminated; they return false (and add
// nothing more) once the buffer is full.
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace roar {

bool append(char* buf, size_t cap, size_t* len, const char* text);
bool append_uint(char* buf, size_t cap, size_t* len, uint32_t value);  // decimal
// Lowercase hex, at least min_digits digits (zero-padded).
bool append_hex(char* buf, size_t cap, size_t* len, uint32_t value, uint8_t min_digits);
bool append_int(char* buf, size_t cap, size_t* len, int32_t value);    // decimal, '-' when negative

// True when text[0..length) is exactly the NUL-terminated word.
bool equals(const char* text, size_t length, const char* word);

}  // namespace roar
