// The values of one diagnostics period (per-frame latencies, processing times) and their order
// statistics, for the "Processing" status: users of a detector node check now - header.stamp
// first, and a mean hides the slow frames a controller notices.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace spool_vision
{
class SampleWindow
{
public:
  void add(double value)
  {
    values_.push_back(value);
  }
  bool empty() const
  {
    return values_.empty();
  }
  std::size_t size() const
  {
    return values_.size();
  }
  /// The nearest-rank q-quantile (q in [0, 1]: the smallest value with at least q of the values at
  /// or below it); NaN when empty. Reorders the values.
  double quantile(double q)
  {
    if (values_.empty())
      return std::numeric_limits<double>::quiet_NaN();
    const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(values_.size()));
    const std::size_t index = rank < 1.0 ? 0 : static_cast<std::size_t>(rank) - 1;
    std::nth_element(values_.begin(), values_.begin() + static_cast<std::ptrdiff_t>(index), values_.end());
    return values_[index];
  }
  /// Empties the window; its memory stays for the next period (no allocation per frame).
  void clear()
  {
    values_.clear();
  }

private:
  std::vector<double> values_;
};

}  // namespace spool_vision
