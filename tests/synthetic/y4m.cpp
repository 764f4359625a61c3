#include "y4m.hpp"

#include <cstring>
#include <stdexcept>
#include <string>

namespace uavstab::synthetic {

Y4mWriter::Y4mWriter(const std::string &path, int width, int height, int fps_num, int fps_den)
    : file_(std::fopen(path.c_str(), "wb"), &std::fclose), width_(width), height_(height)
{
    if (!file_)
        throw std::runtime_error("cannot write " + path);
    std::fprintf(file_.get(), "YUV4MPEG2 W%d H%d F%d:%d Ip A1:1 C420jpeg\n", width, height, fps_num, fps_den);
}

void Y4mWriter::write(const FrameView &frame)
{
    if (frame.format != PixelFormat::I420 || frame.width != width_ || frame.height != height_)
        throw std::invalid_argument("Y4mWriter: frame is not I420 of the stream's size");
    std::fputs("FRAME\n", file_.get());
    for (int p = 0; p < 3; ++p)
        for (int y = 0; y < frame.planeHeight(p); ++y)
            std::fwrite(frame.planes[p].data + std::size_t(y) * frame.planes[p].stride, 1,
                        std::size_t(frame.planeWidth(p)), file_.get());
}

Y4mReader::Y4mReader(const std::string &path)
    : file_(std::fopen(path.c_str(), "rb"), &std::fclose)
{
    if (!file_)
        throw std::runtime_error("cannot read " + path);
    char line[512];
    if (!std::fgets(line, sizeof line, file_.get()) || std::strncmp(line, "YUV4MPEG2 ", 10) != 0)
        throw std::runtime_error(path + " is not a YUV4MPEG2 file");
    for (char *tok = std::strtok(line + 10, " \n"); tok; tok = std::strtok(nullptr, " \n")) {
        if (tok[0] == 'W')
            width_ = std::atoi(tok + 1);
        else if (tok[0] == 'H')
            height_ = std::atoi(tok + 1);
        else if (tok[0] == 'F')
            std::sscanf(tok + 1, "%d:%d", &fps_num_, &fps_den_);
        else if (tok[0] == 'C' && std::strncmp(tok + 1, "420", 3) != 0)
            throw std::runtime_error(path + ": only 4:2:0 y4m is supported");
    }
    if (width_ <= 0 || height_ <= 0)
        throw std::runtime_error(path + ": no frame size in header");
}

bool Y4mReader::read(FrameBuffer &frame)
{
    char line[256];
    if (!std::fgets(line, sizeof line, file_.get()))
        return false;
    if (std::strncmp(line, "FRAME", 5) != 0)
        throw std::runtime_error("y4m: expected FRAME");
    if (frame.format() != PixelFormat::I420 || frame.width() != width_ || frame.height() != height_)
        frame = FrameBuffer(PixelFormat::I420, width_, height_);
    for (int p = 0; p < 3; ++p)
        for (int y = 0; y < frame.view().planeHeight(p); ++y) {
            const std::size_t n = std::size_t(frame.view().planeWidth(p));
            if (std::fread(frame.row(p, y), 1, n, file_.get()) != n)
                return false;
        }
    return true;
}

} // namespace uavstab::synthetic
