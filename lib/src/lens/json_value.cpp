#include "lens/json_value.hpp"

#include <cstdlib>
#include <stdexcept>

namespace uavstab {

const JsonValue *JsonValue::find(const std::string &key) const
{
    if (type != Type::Object)
        return nullptr;
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &it->second;
}

namespace {

class Parser {
public:
    explicit Parser(const std::string &text) : s_(text) {}

    JsonValue document()
    {
        JsonValue v = value(0);
        space();
        if (i_ != s_.size())
            fail("text after the end of the document");
        return v;
    }

private:
    static constexpr int kMaxDepth = 64;

    [[noreturn]] void fail(const std::string &what) const
    {
        int line = 1;
        for (std::size_t k = 0; k < i_ && k < s_.size(); ++k)
            line += s_[k] == '\n';
        throw std::runtime_error("line " + std::to_string(line) + ": " + what);
    }

    void space()
    {
        while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
            ++i_;
    }

    bool literal(const char *word)
    {
        std::size_t k = 0;
        while (word[k] && i_ + k < s_.size() && s_[i_ + k] == word[k])
            ++k;
        if (word[k])
            return false;
        i_ += k;
        return true;
    }

    JsonValue value(int depth)
    {
        if (depth > kMaxDepth)
            fail("nested too deeply");
        space();
        if (i_ >= s_.size())
            fail("unexpected end of the text");
        JsonValue v;
        const char c = s_[i_];
        if (c == '{') {
            v.type = JsonValue::Type::Object;
            ++i_;
            space();
            if (i_ < s_.size() && s_[i_] == '}') {
                ++i_;
                return v;
            }
            for (;;) {
                space();
                if (i_ >= s_.size() || s_[i_] != '"')
                    fail("expected a member name in quotes");
                std::string key = string();
                space();
                if (i_ >= s_.size() || s_[i_] != ':')
                    fail("expected ':' after \"" + key + "\"");
                ++i_;
                v.object[key] = value(depth + 1);
                space();
                if (i_ < s_.size() && s_[i_] == ',') {
                    ++i_;
                    continue;
                }
                if (i_ < s_.size() && s_[i_] == '}') {
                    ++i_;
                    return v;
                }
                fail("expected ',' or '}'");
            }
        }
        if (c == '[') {
            v.type = JsonValue::Type::Array;
            ++i_;
            space();
            if (i_ < s_.size() && s_[i_] == ']') {
                ++i_;
                return v;
            }
            for (;;) {
                v.array.push_back(value(depth + 1));
                space();
                if (i_ < s_.size() && s_[i_] == ',') {
                    ++i_;
                    continue;
                }
                if (i_ < s_.size() && s_[i_] == ']') {
                    ++i_;
                    return v;
                }
                fail("expected ',' or ']'");
            }
        }
        if (c == '"') {
            v.type = JsonValue::Type::String;
            v.string = string();
            return v;
        }
        if (literal("null"))
            return v;
        if (literal("true")) {
            v.type = JsonValue::Type::Bool;
            v.boolean = true;
            return v;
        }
        if (literal("false")) {
            v.type = JsonValue::Type::Bool;
            return v;
        }
        if (c == '-' || (c >= '0' && c <= '9')) {
            const char *begin = s_.c_str() + i_;
            char *end = nullptr;
            v.type = JsonValue::Type::Number;
            v.number = std::strtod(begin, &end);
            if (end == begin)
                fail("malformed number");
            i_ += std::size_t(end - begin);
            return v;
        }
        fail(std::string("unexpected character '") + c + "'");
    }

    static void appendUtf8(std::string &out, unsigned cp)
    {
        if (cp < 0x80) {
            out += char(cp);
        } else if (cp < 0x800) {
            out += char(0xC0 | (cp >> 6));
            out += char(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
            out += char(0xE0 | (cp >> 12));
            out += char(0x80 | ((cp >> 6) & 0x3F));
            out += char(0x80 | (cp & 0x3F));
        } else {
            out += char(0xF0 | (cp >> 18));
            out += char(0x80 | ((cp >> 12) & 0x3F));
            out += char(0x80 | ((cp >> 6) & 0x3F));
            out += char(0x80 | (cp & 0x3F));
        }
    }

    unsigned hex4()
    {
        if (i_ + 4 > s_.size())
            fail("short \\u escape");
        unsigned cp = 0;
        for (int k = 0; k < 4; ++k) {
            const char h = s_[i_++];
            cp <<= 4;
            if (h >= '0' && h <= '9')
                cp |= unsigned(h - '0');
            else if (h >= 'a' && h <= 'f')
                cp |= unsigned(h - 'a' + 10);
            else if (h >= 'A' && h <= 'F')
                cp |= unsigned(h - 'A' + 10);
            else
                fail("malformed \\u escape");
        }
        return cp;
    }

    std::string string()
    {
        ++i_;  // the opening quote
        std::string out;
        while (i_ < s_.size() && s_[i_] != '"') {
            char c = s_[i_++];
            if (c != '\\') {
                out += c;
                continue;
            }
            if (i_ >= s_.size())
                break;
            c = s_[i_++];
            switch (c) {
            case '"': case '\\': case '/': out += c; break;
            case 'b': out += '\b'; break;
            case 'f': out += '\f'; break;
            case 'n': out += '\n'; break;
            case 'r': out += '\r'; break;
            case 't': out += '\t'; break;
            case 'u': {
                unsigned cp = hex4();
                if (cp >= 0xD800 && cp < 0xDC00 && i_ + 1 < s_.size() && s_[i_] == '\\' && s_[i_ + 1] == 'u') {
                    i_ += 2;
                    const unsigned low = hex4();
                    cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                }
                appendUtf8(out, cp);
                break;
            }
            default: fail(std::string("unknown escape \\") + c);
            }
        }
        if (i_ >= s_.size())
            fail("unterminated string");
        ++i_;  // the closing quote
        return out;
    }

    const std::string &s_;
    std::size_t i_ = 0;
};

} // namespace

JsonValue parseJson(const std::string &text)
{
    return Parser(text).document();
}

} // namespace uavstab
