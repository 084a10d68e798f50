#include "calibd/core/common/text_format.hpp"

#include <iomanip>
#include <sstream>

namespace calibd {

std::string FixedDecimal(double v, int decimals) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(decimals) << v;
  return o.str();
}

}  // namespace calibd
