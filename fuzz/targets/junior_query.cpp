// The Junior's query string (roar/junior_control.h): applied, or refused with one of the
// spec's reasons and nothing changed; duties are never beyond full scale either way.
#include <string.h>

#include "harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::Object junior(roar_junior_size()), fresh(roar_junior_size());
  roar_junior_init(junior);
  roar_junior_init(fresh);
  int16_t left = 0, right = 0, left0 = 0, right0 = 0;
  const int r = roar_junior_apply_query(junior, reinterpret_cast<const char*>(data), size, 1000);
  roar_junior_duties(junior, 1000, &left, &right);
  CHECK(left >= -1000 && left <= 1000 && right >= -1000 && right <= 1000);
  if (r < 0) {
    CHECK(r >= -3);
    roar_junior_duties(fresh, 1000, &left0, &right0);
    CHECK(left == left0 && right == right0);  // a refused query changes nothing
  }
  return 0;
}
