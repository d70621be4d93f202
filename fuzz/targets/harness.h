// What every libFuzzer target here shares: the core's objects behind the C ABI (c_api.h, the
// one declaration of what crosses it), and CHECK, which stops the run on a broken invariant
// with the invariant's text (libFuzzer saves the input that broke it).
#pragma once
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <memory>

#include "c_api.h"
#include "roar/protocol.h"

#define CHECK(cond)                                                               \
  do {                                                                            \
    if (!(cond)) {                                                                \
      fprintf(stderr, "invariant broken at %s:%d: %s\n", __FILE__, __LINE__, #cond); \
      abort();                                                                    \
    }                                                                             \
  } while (0)

namespace fuzz {

namespace proto = roar::proto;
using roar::kParseResultCount;
using roar::kSbusResultCount;
using roar::ParseResult;
using roar::SbusResult;

// A core object of size_fn() bytes, aligned as any object, zeroed.
class Object {
 public:
  explicit Object(size_t bytes) : mem_(new max_align_t[(bytes + sizeof(max_align_t) - 1) / sizeof(max_align_t)]()) {}
  operator void*() { return mem_.get(); }
  operator const void*() const { return mem_.get(); }

 private:
  std::unique_ptr<max_align_t[]> mem_;
};

inline bool pulse_ok(uint16_t us) { return us >= proto::kControlMinUs && us <= proto::kControlMaxUs; }

}  // namespace fuzz
