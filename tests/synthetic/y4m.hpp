// Minimal YUV4MPEG2 (I420) reading and writing: the raw clip format the demo hands to
// GStreamer (y4mdec) and ffmpeg without any encoder in between.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include "uavstab/frame_buffer.hpp"

namespace uavstab::synthetic {

class Y4mWriter {
public:
    Y4mWriter(const std::string &path, int width, int height, int fps_num, int fps_den);
    void write(const FrameView &i420);

private:
    std::unique_ptr<std::FILE, int (*)(std::FILE *)> file_;
    int width_, height_;
};

class Y4mReader {
public:
    explicit Y4mReader(const std::string &path);
    int width() const { return width_; }
    int height() const { return height_; }
    int fpsNum() const { return fps_num_; }
    int fpsDen() const { return fps_den_; }
    // False at end of file.
    bool read(FrameBuffer &i420);

private:
    std::unique_ptr<std::FILE, int (*)(std::FILE *)> file_;
    int width_ = 0, height_ = 0, fps_num_ = 30, fps_den_ = 1;
};

} // namespace uavstab::synthetic
