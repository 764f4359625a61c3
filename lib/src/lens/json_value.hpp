// A small JSON reader for lens profiles. OpenCV's FileStorage reads JSON too, but refuses
// null and \u escapes, which Gyroflow's profiles use throughout; this reads all of JSON
// (RFC 8259) into a tree.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace uavstab {

struct JsonValue {
    enum class Type { Null, Bool, Number, String, Array, Object };
    Type type = Type::Null;
    bool boolean = false;
    double number = 0.0;
    std::string string;
    std::vector<JsonValue> array;
    std::map<std::string, JsonValue> object;

    // The member `key` of an object, or nullptr (also when this is not an object).
    const JsonValue *find(const std::string &key) const;
    bool isNull() const { return type == Type::Null; }
};

// Throws std::runtime_error("line L: what") on malformed text.
JsonValue parseJson(const std::string &text);

} // namespace uavstab
