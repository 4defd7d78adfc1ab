#pragma once
// dirk's Butcher tables, one per order: stiffly accurate ESDIRKs with stage
// order 2 where SUNDIALS 6.4 has them (the default SDIRK_5_3_4 has stage
// order 1, and RK stages losing order on the stiff contacts is what holds
// imex's steps down in the creep). Not ESDIRK547L2SA2, broken in 6.4.1.
// ARKStep's dirk and the multirate stepper's coarse and fine levels step
// with these (multirate takes orders 3 and 4, whose first stage is explicit).

#include <arkode/arkode_butcher_dirk.h>

#include <stdexcept>

#include "stickslip/case/methods.hpp"

namespace stickslip {

// Order 0 is dirk's default (case/methods.hpp).
inline ARKODE_DIRKTableID dirk_table(int order) {
  switch (order > 0 ? order : method_info(Method::dirk).default_order) {
    case 2:
      return ARKODE_SDIRK_2_1_2;
    case 3:
      return ARKODE_ESDIRK325L2SA_5_2_3;
    case 4:
      return ARKODE_ESDIRK436L2SA_6_3_4;
    case 5:
      return ARKODE_ESDIRK547L2SA_7_4_5;
  }
  throw std::logic_error("dirk_table: an order the case reader should have refused");
}

}  // namespace stickslip
