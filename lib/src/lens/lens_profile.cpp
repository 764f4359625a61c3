// Reading lens calibrations: Gyroflow lens profiles (JSON, json_value.hpp) and OpenCV
// calibrations (cv::FileStorage: YAML, XML or JSON).
#include "uavstab/lens.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>

#include "lens/json_value.hpp"

namespace uavstab {

LensProfileError::LensProfileError(const std::string &file, const std::string &field, const std::string &why)
    : std::runtime_error("lens profile " + file + (field.empty() ? "" : ": " + field) + ": " + why), file_(file),
      field_(field)
{
}

namespace {

std::string baseName(const std::string &path)
{
    const std::size_t slash = path.find_last_of('/');
    std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
    const std::size_t dot = name.find_last_of('.');
    return dot == std::string::npos || dot == 0 ? name : name.substr(0, dot);
}

class GyroflowReader {
public:
    GyroflowReader(const std::string &path, const JsonValue &root) : path_(path), root_(root) {}

    LensProfile read() const
    {
        LensProfile p;
        const JsonValue *name = root_.find("name");
        p.name = name && name->type == JsonValue::Type::String && !name->string.empty() ? name->string
                                                                                         : baseName(path_);
        const JsonValue &dim = member(root_, "calib_dimension", "calib_dimension");
        p.lens.width = positiveInt(member(dim, "w", "calib_dimension.w"), "calib_dimension.w");
        p.lens.height = positiveInt(member(dim, "h", "calib_dimension.h"), "calib_dimension.h");
        for (const char *stretch : {"input_horizontal_stretch", "input_vertical_stretch"}) {
            const JsonValue *v = root_.find(stretch);
            if (v && !v->isNull() && (v->type != JsonValue::Type::Number || std::abs(v->number - 1.0) > 1e-9))
                fail(stretch, "a stretched (anamorphic) picture is not supported; 1.0 is");
        }

        // The model: distortion_model (null: OpenCV fisheye) with its numbers in
        // fisheye_params; or, without distortion_model, the older use_opencv_* flags.
        std::string params = "fisheye_params";
        const JsonValue *model = root_.find("distortion_model");
        if (model && !model->isNull()) {
            if (model->type != JsonValue::Type::String)
                fail("distortion_model", "must be a string or null");
            if (model->string == "opencv_fisheye")
                p.lens.kind = LensKind::Fisheye;
            else if (model->string == "opencv_standard")
                p.lens.kind = LensKind::Standard;
            else
                fail("distortion_model", "\"" + model->string +
                                             "\" is not supported (null, \"opencv_fisheye\" or \"opencv_standard\")");
        } else if (flag("use_opencv_standard") && !flag("use_opencv_fisheye")) {
            p.lens.kind = LensKind::Standard;
            params = "calib_params";
        } else {
            p.lens.kind = LensKind::Fisheye;
        }
        const JsonValue &cam = member(root_, params, params);
        readCameraMatrix(member(cam, "camera_matrix", params + ".camera_matrix"), params + ".camera_matrix", p.lens);
        readCoefficients(member(cam, "distortion_coeffs", params + ".distortion_coeffs"),
                         params + ".distortion_coeffs", p.lens);

        if (const JsonValue *readout = root_.find("frame_readout_time"); readout && !readout->isNull()) {
            // Negative: the sensor reads its rows from the bottom up (Gyroflow's convention).
            if (readout->type != JsonValue::Type::Number || !(std::abs(readout->number) <= 1000.0))
                fail("frame_readout_time", "must be a number of ms, -1000 to 1000, or null");
            p.readout_time = std::abs(readout->number);
            p.readout_bottom_up = readout->number < 0.0;
        }
        if (const JsonValue *gs = root_.find("global_shutter"); gs && !gs->isNull()) {
            if (gs->type != JsonValue::Type::Bool)
                fail("global_shutter", "must be true, false or null");
            p.global_shutter = gs->boolean;
        }
        return p;
    }

private:
    [[noreturn]] void fail(const std::string &field, const std::string &why) const
    {
        throw LensProfileError(path_, field, why);
    }

    const JsonValue &member(const JsonValue &parent, const std::string &key, const std::string &field) const
    {
        const JsonValue *v = parent.find(key);
        if (!v || v->isNull())
            fail(field, "missing");
        return *v;
    }

    bool flag(const char *key) const
    {
        const JsonValue *v = root_.find(key);
        return v && v->type == JsonValue::Type::Bool && v->boolean;
    }

    int positiveInt(const JsonValue &v, const std::string &field) const
    {
        if (v.type != JsonValue::Type::Number || !(v.number >= 1.0 && v.number <= 65536.0) ||
            v.number != std::floor(v.number))
            fail(field, "must be a whole number of pixels, 1-65536");
        return int(v.number);
    }

    double number(const JsonValue &v, const std::string &field) const
    {
        if (v.type != JsonValue::Type::Number || !std::isfinite(v.number))
            fail(field, "must be a number");
        return v.number;
    }

    void readCameraMatrix(const JsonValue &k, const std::string &field, LensModel &lens) const
    {
        if (k.type != JsonValue::Type::Array || k.array.size() != 3)
            fail(field, "must be 3 rows of 3 numbers");
        double m[3][3];
        for (int r = 0; r < 3; ++r) {
            const JsonValue &row = k.array[std::size_t(r)];
            if (row.type != JsonValue::Type::Array || row.array.size() != 3)
                fail(field, "must be 3 rows of 3 numbers");
            for (int c = 0; c < 3; ++c)
                m[r][c] = number(row.array[std::size_t(c)], field);
        }
        if (m[1][0] != 0.0 || m[2][0] != 0.0 || m[2][1] != 0.0 || m[2][2] != 1.0)
            fail(field, "must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
        if (std::abs(m[0][1]) > 1e-6 * std::abs(m[0][0]))
            fail(field, "a skewed camera matrix is not supported");
        lens.fx = m[0][0];
        lens.cx = m[0][2];
        lens.fy = m[1][1];
        lens.cy = m[1][2];
    }

    void readCoefficients(const JsonValue &d, const std::string &field, LensModel &lens) const
    {
        if (d.type != JsonValue::Type::Array)
            fail(field, "must be a list of numbers");
        const std::size_t need = lens.kind == LensKind::Fisheye ? 4 : 5;
        if (d.array.size() < 4)
            fail(field, "has " + std::to_string(d.array.size()) + " values, the model needs " + std::to_string(need));
        for (std::size_t i = 0; i < d.array.size(); ++i) {
            const double c = number(d.array[i], field);
            if (i < need)
                lens.coeffs[i] = c;
            else if (c != 0.0)
                fail(field, "has " + std::to_string(d.array.size()) + " values; the model takes " +
                                std::to_string(need) + " (the others must be 0)");
        }
    }

    const std::string &path_;
    const JsonValue &root_;
};

LensProfile readOpenCvCalibrationFields(const std::string &path);

// Any error OpenCV raises while reading (a file whose root is not a map, a malformed node;
// its YAML parser can also throw std::length_error on some broken files) is the file's: it
// is reported as the profile's, not let through.
LensProfile readOpenCvCalibration(const std::string &path)
{
    try {
        return readOpenCvCalibrationFields(path);
    } catch (const LensProfileError &) {
        throw;
    } catch (const cv::Exception &e) {
        throw LensProfileError(path, "", std::string("is not a readable OpenCV calibration (") + e.err + ")");
    } catch (const std::exception &e) {
        throw LensProfileError(path, "", std::string("is not a readable OpenCV calibration (") + e.what() + ")");
    }
}

// OpenCV 4.6's YAML reader never returns on two shapes of malformed file (found by
// tests/fuzz/fuzz_lens_profile.cpp): a line beginning with "--" that is no document marker
// ("---"), and a line indented less than the file's first key (" s: 0\nabc-\nx: 1").
// Neither is valid YAML, and calibration files have none: they are refused before the reader
// sees them. OpenCV writes its keys unindented and JSON and XML files begin unindented, so for
// them no line can be indented less. Brackets are not followed: an unclosed one would hide
// the lines after it.
void refuseWhatHangsOpenCvsParser(const std::string &path)
{
    std::ifstream in(path, std::ios::binary);
    std::string line;
    std::size_t top = std::string::npos;  // the first key's indentation
    auto refuse = [&](int number, const std::string &why) {
        throw LensProfileError(path, "", "is not a readable OpenCV calibration (line " + std::to_string(number) + " " +
                                             why + ")");
    };
    for (int number = 1; std::getline(in, line); ++number) {
        const std::size_t first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos)
            continue;
        if (line.compare(first, 2, "--") == 0 && line.compare(first, 3, "---") != 0)
            refuse(number, "begins with \"--\"");
        const bool marker = line[first] == '#' || line[first] == '%' || line.compare(first, 3, "---") == 0 ||
                            line.compare(first, 3, "...") == 0;
        if (marker)
            continue;
        if (top == std::string::npos)
            top = first;
        else if (first < top)
            refuse(number, "is indented less than the first key");
    }
}

LensProfile readOpenCvCalibrationFields(const std::string &path)
{
    refuseWhatHangsOpenCvsParser(path);
    cv::FileStorage fs;
    try {
        if (!fs.open(path, cv::FileStorage::READ))
            throw LensProfileError(path, "", "is neither a Gyroflow lens profile nor an OpenCV calibration");
    } catch (const cv::Exception &e) {
        throw LensProfileError(path, "", std::string("is neither a Gyroflow lens profile nor an OpenCV calibration (") +
                                             e.err + ")");
    }
    auto fail = [&](const std::string &field, const std::string &why) { throw LensProfileError(path, field, why); };
    auto matrix = [&](const char *key) {
        cv::Mat m;
        const cv::FileNode n = fs[key];
        if (n.empty() || n.isNone())
            fail(key, "missing");
        // OpenCV allocates what rows x cols says before it reads the data: a calibration's
        // matrices are small, and a file claiming more is refused before that.
        constexpr int kMaxEntries = 16;
        if (!n.isMap())
            fail(key, "is not a matrix");
        const cv::FileNode rows = n["rows"], cols = n["cols"], data = n["data"];
        if (!rows.isInt() || !cols.isInt() || int(rows) < 1 || int(cols) < 1 || int(rows) > kMaxEntries ||
            int(cols) > kMaxEntries || int(rows) * int(cols) > kMaxEntries)
            fail(key, "must be a matrix of at most " + std::to_string(kMaxEntries) + " values");
        if (!data.isSeq() || int(data.size()) != int(rows) * int(cols))
            fail(key, "must hold rows x cols values");
        try {
            n >> m;
        } catch (const cv::Exception &) {
            fail(key, "is not a matrix");
        }
        if (m.empty())
            fail(key, "is not a matrix");
        m.convertTo(m, CV_64F);
        return m;
    };
    auto size = [&](const char *key) {
        const cv::FileNode n = fs[key];
        if (!n.isInt() || int(n) < 1 || int(n) > 65536)
            fail(key, n.empty() ? "missing" : "must be a whole number of pixels, 1-65536");
        return int(n);
    };
    LensProfile p;
    p.name = baseName(path);
    const cv::Mat k = matrix("camera_matrix");
    if (k.rows != 3 || k.cols != 3)
        fail("camera_matrix", "must be 3x3");
    if (k.at<double>(1, 0) != 0.0 || k.at<double>(2, 0) != 0.0 || k.at<double>(2, 1) != 0.0 ||
        k.at<double>(2, 2) != 1.0)
        fail("camera_matrix", "must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
    if (std::abs(k.at<double>(0, 1)) > 1e-6 * std::abs(k.at<double>(0, 0)))
        fail("camera_matrix", "a skewed camera matrix is not supported");
    p.lens.fx = k.at<double>(0, 0);
    p.lens.cx = k.at<double>(0, 2);
    p.lens.fy = k.at<double>(1, 1);
    p.lens.cy = k.at<double>(1, 2);
    const cv::Mat d = matrix("distortion_coefficients");
    if (d.rows != 1 && d.cols != 1)
        fail("distortion_coefficients", "must be one row or one column");
    const int count = int(d.total());
    // Which model: fisheye_model (OpenCV's calibration sample) or distortion_model (ROS
    // camera_info); else 4 values are cv::fisheye::calibrate's, 5 cv::calibrateCamera's.
    bool fisheye = count == 4;
    if (const cv::FileNode n = fs["fisheye_model"]; n.isInt())
        fisheye = int(n) != 0;
    else if (const cv::FileNode m = fs["distortion_model"]; m.isString()) {
        const std::string model = std::string(m);
        if (model == "fisheye" || model == "equidistant")
            fisheye = true;
        else if (model == "plumb_bob" || model == "radtan" || model == "standard")
            fisheye = false;
        else
            fail("distortion_model", "\"" + model + "\" is not supported (fisheye, equidistant, plumb_bob)");
    }
    p.lens.kind = fisheye ? LensKind::Fisheye : LensKind::Standard;
    const int need = fisheye ? 4 : 5;
    if (count < 4)
        fail("distortion_coefficients", "has " + std::to_string(count) + " values, the model needs " + std::to_string(need));
    for (int i = 0; i < count; ++i) {
        const double c = d.at<double>(i);
        if (i < need)
            p.lens.coeffs[std::size_t(i)] = c;
        else if (c != 0.0)
            fail("distortion_coefficients", "has " + std::to_string(count) + " values; the model takes " +
                                                std::to_string(need) + " (the others must be 0)");
    }
    p.lens.width = size("image_width");
    p.lens.height = size("image_height");
    return p;
}

} // namespace

LensProfile readLensProfile(const std::string &path)
{
    std::ifstream f(path, std::ios::binary);
    if (!f)
        throw LensProfileError(path, "", "cannot be opened");
    // A calibration is a few kB: a larger file (a video given by mistake) is refused unread.
    constexpr std::streamoff kMaxBytes = 1 << 20;
    f.seekg(0, std::ios::end);
    if (f.tellg() > kMaxBytes)
        throw LensProfileError(path, "", "is larger than 1 MiB: not a calibration file");
    f.seekg(0, std::ios::beg);
    std::ostringstream text;
    text << f.rdbuf();
    if (f.bad())
        throw LensProfileError(path, "", "cannot be read");
    const std::string s = text.str();
    LensProfile p;
    // Gyroflow's profiles are JSON objects with calib_dimension; anything else goes to
    // cv::FileStorage.
    const std::size_t first = s.find_first_not_of(" \t\r\n");
    bool gyroflow = false;
    JsonValue root;
    if (first != std::string::npos && s[first] == '{') {
        try {
            root = parseJson(s);
        } catch (const std::exception &e) {
            throw LensProfileError(path, "", std::string("is not valid JSON (") + e.what() + ")");
        }
        gyroflow = root.find("calib_dimension") != nullptr || root.find("fisheye_params") != nullptr;
    }
    p = gyroflow ? GyroflowReader(path, root).read() : readOpenCvCalibration(path);
    try {
        p.lens.validate();
    } catch (const std::invalid_argument &e) {
        throw LensProfileError(path, "", e.what());
    }
    return p;
}

} // namespace uavstab
