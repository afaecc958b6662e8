// A value layer's styles and colour scales (ValueLayer.hpp).
#include <tellus/proxy/ValueLayer.hpp>

#include <algorithm>

namespace tellus {

bool ValueLayerSpec::offers(std::string_view name) const noexcept {
  return std::find(styles.begin(), styles.end(), name) != styles.end();
}

values::ColourScale ValueLayerSpec::scale(const values::ColourMap& map,
                                          std::span<const float> data) const {
  values::ColourScale s{&map, min, max, scaling, outOfRange};
  if (rangeFromData) {
    const auto range =
        values::rangeFromData(data, lowPercent, highPercent, scaling == values::Scaling::Log);
    s.min = range ? range->min : (scaling == values::Scaling::Log ? 1.0 : 0.0);
    s.max = range ? range->max : (scaling == values::Scaling::Log ? 10.0 : 1.0);
  }
  return s;
}

} // namespace tellus
