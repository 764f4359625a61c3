// Excluded regions (StabilizerConfig::exclude) as text, the way gst-launch takes them:
// "x,y,w,h;x,y,w,h" -- one rectangle per ';'-separated group, four numbers in fractions of
// the frame (x, y: top-left corner in 0..1; w, h: size, > 0, the rectangle inside the
// frame). Spaces around numbers are allowed, and so are empty groups ("a;;b", a trailing
// ';'); the empty string is no rectangle. The element's `exclude` property and the library
// read and check the text with these functions only, so they accept the same strings.
#pragma once

#include <string>
#include <vector>

#include "uavstab/config.hpp"

namespace uavstab {

// At most this many rectangles.
constexpr int kMaxExcludeRects = 64;

// Why the rectangle is not acceptable ("" when it is): coordinates in [0, 1], w and h > 0,
// x + w <= 1 and y + h <= 1 (within 1e-9, for decimal rounding), no NaN.
std::string checkRect(const RectF &rect);
// Why the list is not acceptable (the first bad rectangle, or too many), or "".
std::string checkRects(const std::vector<RectF> &rects);

// Parses the text; on success stores the rectangles and returns true. On failure leaves
// `rects` untouched, puts the reason in `error` (when given) and returns false.
bool parseRects(const std::string &text, std::vector<RectF> &rects, std::string *error = nullptr);
// The text of a list, parseable back to the same numbers ("" for none).
std::string formatRects(const std::vector<RectF> &rects);

} // namespace uavstab
