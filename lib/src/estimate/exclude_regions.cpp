#include "estimate/exclude_regions.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

namespace uavstab {

namespace {

constexpr double kSlack = 1e-9;

bool isSpace(char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

std::string trim(const std::string &s)
{
    std::size_t b = 0, e = s.size();
    while (b < e && isSpace(s[b]))
        ++b;
    while (e > b && isSpace(s[e - 1]))
        --e;
    return s.substr(b, e - b);
}

// A number in the C locale (never the user's: "0,5" is two numbers here), finite.
bool parseNumber(const std::string &text, double &value)
{
    const std::string t = trim(text);
    if (t.empty())
        return false;
    const char *begin = t.data(), *end = t.data() + t.size();
    if (*begin == '+')  // from_chars refuses a leading '+'; people write it
        ++begin;
    const auto result = std::from_chars(begin, end, value);
    return result.ec == std::errc() && result.ptr == end && std::isfinite(value);
}

std::string describe(const RectF &r)
{
    std::ostringstream out;
    out << r.x << "," << r.y << "," << r.w << "," << r.h;
    return out.str();
}

} // namespace

std::string checkRect(const RectF &r)
{
    for (const double v : {r.x, r.y, r.w, r.h})
        if (!(v >= 0.0 && v <= 1.0))
            return "rectangle " + describe(r) + ": every number must be in [0, 1]";
    if (!(r.w > 0.0 && r.h > 0.0))
        return "rectangle " + describe(r) + ": width and height must be > 0";
    if (r.x + r.w > 1.0 + kSlack || r.y + r.h > 1.0 + kSlack)
        return "rectangle " + describe(r) + ": must lie inside the frame (x + w <= 1, y + h <= 1)";
    return "";
}

std::string checkRects(const std::vector<RectF> &rects)
{
    if (rects.size() > std::size_t(kMaxExcludeRects))
        return "at most " + std::to_string(kMaxExcludeRects) + " rectangles (got " + std::to_string(rects.size()) +
               ")";
    for (const RectF &r : rects) {
        const std::string why = checkRect(r);
        if (!why.empty())
            return why;
    }
    return "";
}

bool parseRects(const std::string &text, std::vector<RectF> &rects, std::string *error)
{
    auto fail = [&](const std::string &why) {
        if (error)
            *error = why;
        return false;
    };
    std::vector<RectF> parsed;
    std::size_t start = 0;
    while (start <= text.size()) {
        std::size_t stop = text.find(';', start);
        if (stop == std::string::npos)
            stop = text.size();
        const std::string group = text.substr(start, stop - start);
        start = stop + 1;
        if (trim(group).empty())
            continue;
        double v[4];
        std::size_t from = 0;
        int n = 0;
        for (;; ++n) {
            const std::size_t comma = group.find(',', from);
            const std::string item = group.substr(from, comma == std::string::npos ? std::string::npos : comma - from);
            if (n >= 4)
                return fail("'" + trim(group) + "': a rectangle is four numbers x,y,w,h");
            if (!parseNumber(item, v[n]))
                return fail("'" + trim(group) + "': '" + trim(item) + "' is not a number");
            if (comma == std::string::npos)
                break;
            from = comma + 1;
        }
        if (n != 3)
            return fail("'" + trim(group) + "': a rectangle is four numbers x,y,w,h");
        parsed.push_back({v[0], v[1], v[2], v[3]});
        if (parsed.size() > std::size_t(kMaxExcludeRects))
            return fail("at most " + std::to_string(kMaxExcludeRects) + " rectangles");
        const std::string why = checkRect(parsed.back());
        if (!why.empty())
            return fail(why);
    }
    rects = std::move(parsed);
    return true;
}

std::string formatRects(const std::vector<RectF> &rects)
{
    std::string text;
    for (const RectF &r : rects) {
        if (!text.empty())
            text += ';';
        for (int k = 0; k < 4; ++k) {
            const double v = k == 0 ? r.x : k == 1 ? r.y : k == 2 ? r.w : r.h;
            char buffer[32];
            // Shortest text that reads back to the same double.
            const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
            if (k)
                text += ',';
            text.append(buffer, result.ptr);
        }
    }
    return text;
}

} // namespace uavstab
