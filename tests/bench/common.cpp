#include "common.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <dirent.h>
#include <malloc.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "format_conversion.hpp"
#include "shaky_flight.hpp"

namespace bench {

using namespace uavstab;

double secondsBetween(Clock::time_point a, Clock::time_point b)
{
    return std::chrono::duration<double>(b - a).count();
}

double msBetween(Clock::time_point a, Clock::time_point b)
{
    return std::chrono::duration<double, std::milli>(b - a).count();
}

double median(std::vector<double> v)
{
    return percentile(std::move(v), 50.0);
}

double percentile(std::vector<double> v, double p)
{
    if (v.empty())
        return std::nan("");
    std::sort(v.begin(), v.end());
    const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * double(v.size() - 1);
    const std::size_t lo = std::size_t(std::floor(pos));
    const std::size_t hi = std::min(v.size() - 1, lo + 1);
    return v[lo] + (pos - double(lo)) * (v[hi] - v[lo]);
}

double mean(const std::vector<double> &v)
{
    return v.empty() ? std::nan("") : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
}

double minOf(const std::vector<double> &v)
{
    return v.empty() ? std::nan("") : *std::min_element(v.begin(), v.end());
}

double maxOf(const std::vector<double> &v)
{
    return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end());
}

std::string format(const char *fmt, ...)
{
    // Any length: the report's paragraphs are longer than a fixed buffer.
    va_list args, again;
    va_start(args, fmt);
    va_copy(again, args);
    const int n = std::vsnprintf(nullptr, 0, fmt, args);
    va_end(args);
    std::string s(std::size_t(std::max(n, 0)) + 1, '\0');
    std::vsnprintf(s.data(), s.size(), fmt, again);
    va_end(again);
    s.resize(std::size_t(std::max(n, 0)));
    return s;
}

std::string spread(const std::vector<double> &v, const char *number_format)
{
    if (v.empty())
        return "n/a";
    const std::string f = std::string(number_format) + " (" + number_format + "-" + number_format + ")";
    return format(f.c_str(), median(v), minOf(v), maxOf(v));
}

// ---- memory ------------------------------------------------------------------------

namespace {
long statusField(const char *name)
{
    std::ifstream status("/proc/self/status");
    std::string line;
    const std::size_t n = std::strlen(name);
    while (std::getline(status, line))
        if (line.compare(0, n, name) == 0)
            return std::atol(line.c_str() + n + 1);
    return -1;
}
} // namespace

double cpuSeconds(clockid_t clock)
{
    timespec ts{};
    clock_gettime(clock, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

long rssKiB()
{
    return statusField("VmRSS");
}

long peakRssKiB()
{
    return statusField("VmHWM");
}

bool resetPeakRss()
{
    std::ofstream f("/proc/self/clear_refs");
    f << "5";
    f.flush();
    return bool(f);
}

long heapInUseKiB()
{
    const struct mallinfo2 m = mallinfo2();
    return long((m.uordblks + m.hblkhd) / 1024);
}

// ---- load --------------------------------------------------------------------------

LoadMonitor::Sample LoadMonitor::sample()
{
    Sample s;
    s.time = Clock::now();
    std::ifstream stat("/proc/stat");
    std::string cpu;
    double user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
    stat >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal;
    const double hz = double(sysconf(_SC_CLK_TCK));
    s.busy = (user + nice + system + irq + softirq) / hz;
    s.steal = steal / hz;
    rusage self{}, children{};
    getrusage(RUSAGE_SELF, &self);
    getrusage(RUSAGE_CHILDREN, &children);
    auto secs = [](const timeval &t) { return double(t.tv_sec) + t.tv_usec * 1e-6; };
    s.own = secs(self.ru_utime) + secs(self.ru_stime) + secs(children.ru_utime) + secs(children.ru_stime);
    return s;
}

void LoadMonitor::restart()
{
    start_ = sample();
}

double LoadMonitor::foreignShare() const
{
    const Sample now = sample();
    const double wall = secondsBetween(start_.time, now.time) * double(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
    if (wall <= 0)
        return 0;
    return std::max(0.0, ((now.busy - start_.busy) - (now.own - start_.own)) / wall);
}

double LoadMonitor::stealShare() const
{
    const Sample now = sample();
    const double wall = secondsBetween(start_.time, now.time) * double(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
    return wall <= 0 ? 0 : std::max(0.0, (now.steal - start_.steal) / wall);
}

std::string LoadMonitor::describe() const
{
    return format("%.0f %% of the CPUs' time went to other processes and %.0f %% was stolen by the hypervisor",
                  100 * foreignShare(), 100 * stealShare());
}

bool waitQuiet(double max_seconds, double share)
{
    const auto until = Clock::now() + std::chrono::duration<double>(max_seconds);
    bool said = false;
    for (;;) {
        LoadMonitor m;
        ::usleep(1000000);
        if (m.foreignShare() < share)
            return true;
        if (Clock::now() > until)
            return false;
        if (!said) {
            std::printf("  (waiting: other processes use %.0f %% of the CPUs)\n", 100 * m.foreignShare());
            std::fflush(stdout);
            said = true;
        }
    }
}

double measureQuietly(const std::string &what, const std::function<void()> &measure)
{
    for (int attempt = 1;; ++attempt) {
        waitQuiet();
        LoadMonitor m;
        measure();
        const double foreign = m.foreignShare();
        if (foreign < 0.15 || attempt == 3)
            return foreign;
        std::printf("  (%s: other processes took %.0f %% of the CPUs meanwhile; measuring again)\n", what.c_str(),
                    100 * foreign);
        std::fflush(stdout);
    }
}

std::string loadCell(double share)
{
    return format(share >= 0.15 ? "**%.0f %%**" : "%.0f %%", 100 * share);
}

// ---- options / results ----------------------------------------------------------------

bool Options::wants(const std::string &section) const
{
    return only.empty() || std::find(only.begin(), only.end(), section) != only.end();
}

Options parseOptions(int argc, char **argv, const char *usage, const std::vector<std::string> &sections,
                     const std::vector<std::string> &program_flags)
{
    Options o;
    auto refuse = [&](const std::string &why) { throw std::invalid_argument(why + "\n" + usage); };
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "-h" || a == "--help") {
            std::printf("%s", usage);
            std::exit(0);
        }
        auto value = [&]() -> std::string {
            if (i + 1 >= argc)
                throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "--quick")
            o.quick = true;
        else if (a == "--out")
            o.out_dir = value();
        else if (a == "--only") {
            o.only.push_back(value());
            if (std::find(sections.begin(), sections.end(), o.only.back()) == sections.end())
                refuse("no section \"" + o.only.back() + "\"");
        }
        else if (a == "--data")
            o.data_dir = value();
        else if (a == "--resolution")
            o.resolutions.push_back(value());
        else if (std::find(program_flags.begin(), program_flags.end(), a) != program_flags.end()) {
            o.rest.push_back(a);
            o.rest.push_back(value());
        } else
            refuse("unknown argument \"" + a + "\"");
    }
    ::mkdir(o.out_dir.c_str(), 0755);
    return o;
}

void putResult(const Options &o, const std::string &key, double value)
{
    putResultText(o, key, format("%.6g", value));
}

void putResultText(const Options &o, const std::string &key, const std::string &value)
{
    std::ofstream f(o.out_dir + "/summary.tsv", std::ios::app);
    f << key << '\t' << value << '\n';
}

std::string Table::markdown() const
{
    std::ostringstream s;
    auto line = [&](const std::vector<std::string> &cells) {
        s << '|';
        for (const auto &c : cells)
            s << ' ' << c << " |";
        s << '\n';
    };
    line(header_);
    s << '|';
    for (std::size_t i = 0; i < header_.size(); ++i)
        s << (i == 0 ? "---|" : "---:|");
    s << '\n';
    for (const auto &r : rows_)
        line(r);
    return s.str();
}

Fragment::Fragment(const Options &o, const std::string &name)
    : file_(std::fopen((o.out_dir + "/" + name + ".md").c_str(), "w"))
{
    if (!file_)
        throw std::runtime_error("cannot write fragment " + name);
}

Fragment::~Fragment()
{
    const std::string load = "While this section ran, " + load_.describe() + ".";
    std::fprintf(file_, "_%s_\n\n", load.c_str());
    std::printf("%s\n", load.c_str());
    std::fclose(file_);
}

void Fragment::text(const std::string &s)
{
    std::fprintf(file_, "%s\n\n", s.c_str());
    std::fflush(file_);
    std::printf("%s\n", s.c_str());
    std::fflush(stdout);
}

void Fragment::table(const Table &t)
{
    const std::string md = t.markdown();
    std::fprintf(file_, "%s\n", md.c_str());
    std::fflush(file_);
    std::printf("%s\n", md.c_str());
    std::fflush(stdout);
}

void Fragment::line(const std::string &s)
{
    std::fprintf(file_, "%s\n", s.c_str());
    std::fflush(file_);
}

// ---- frames ------------------------------------------------------------------------

std::string Resolution::name() const
{
    return std::to_string(width) + "x" + std::to_string(height);
}

std::vector<Resolution> benchResolutions(const Options &o)
{
    if (!o.resolutions.empty()) {
        std::vector<Resolution> chosen;
        for (const std::string &name : o.resolutions) {
            Resolution r{};
            if (std::sscanf(name.c_str(), "%dx%d", &r.width, &r.height) != 2 || r.width < 16 || r.height < 16)
                throw std::invalid_argument("--resolution wants WxH, got " + name);
            chosen.push_back(r);
        }
        return chosen;
    }
    if (o.quick)
        return {{640, 480}, {1920, 1080}};
    return {{640, 480}, {1280, 720}, {1920, 1080}, {3840, 2160}};
}

ResolutionPlan planFor(const Resolution &r, bool quick)
{
    const long px = long(r.width) * r.height;
    if (px <= 640L * 480)
        return {r, 120, quick ? 400 : 600, quick ? 200 : 300};
    if (px <= 1280L * 720)
        return {r, 100, quick ? 300 : 400, quick ? 120 : 200};
    if (px <= 1920L * 1080)
        return {r, 80, quick ? 200 : 300, quick ? 60 : 100};
    return {r, 40, quick ? 80 : 120, quick ? 24 : 40};
}

std::vector<ResolutionPlan> benchPlans(const Options &o)
{
    std::vector<ResolutionPlan> plans;
    for (const Resolution &r : benchResolutions(o))
        plans.push_back(planFor(r, o.quick));
    return plans;
}

const char *formatName(PixelFormat f)
{
    return toString(f).data();  // names are string literals
}

std::vector<cv::Mat> renderFlight(int width, int height, int count, std::uint32_t seed)
{
    synthetic::FlightOptions options;
    options.width = width;
    options.height = height;
    options.frames = count;
    options.seed = seed;
    options.moving_objects = 2;
    const synthetic::ShakyFlight flight(options);
    std::vector<cv::Mat> frames;
    frames.reserve(std::size_t(count));
    for (int i = 0; i < count; ++i)
        frames.push_back(flight.renderBgr(i));
    return frames;
}

FrameBuffer frameFromBgr(const cv::Mat &bgr, PixelFormat format)
{
    const int width = bgr.cols, height = bgr.rows;
    FrameBuffer f(format, width, height);
    if (format == PixelFormat::I420 && width % 2 == 0 && height % 2 == 0) {
        // OpenCV's converter: much faster than the reference one at 4K, same content.
        cv::Mat yuv;
        cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV_I420);
        std::memcpy(f.row(0, 0), yuv.data, yuv.total());
    } else if (format == PixelFormat::BGRx || format == PixelFormat::BGRA) {
        cv::Mat packed(height, width, CV_8UC4, f.row(0, 0), std::size_t(f.view().planes[0].stride));
        cv::cvtColor(bgr, packed, cv::COLOR_BGR2BGRA);
    } else {
        synthetic::bgrToFrame(bgr, f);
    }
    return f;
}

std::vector<FrameBuffer> framesFromBgr(const std::vector<cv::Mat> &bgr, PixelFormat format)
{
    std::vector<FrameBuffer> frames;
    frames.reserve(bgr.size());
    for (const cv::Mat &m : bgr)
        frames.push_back(frameFromBgr(m, format));
    return frames;
}

int pingPong(long k, int n)
{
    if (n <= 1)
        return 0;
    const long period = 2L * (n - 1);
    const long m = k % period;
    return int(m < n ? m : period - m);
}

std::unique_ptr<FrameBuffer> OutputPool::get()
{
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) {
        ++allocated_;
        return std::make_unique<FrameBuffer>(format_, width_, height_);
    }
    auto b = std::move(free_.back());
    free_.pop_back();
    return b;
}

void OutputPool::put(std::unique_ptr<FrameBuffer> b)
{
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(b));
}

PoolSlot::~PoolSlot()
{
    if (out_)
        pool_.put(std::move(out_));
}

std::optional<FrameView> PoolSlot::acquireOutput()
{
    out_ = pool_.get();
    return out_->view();
}

std::optional<FrameView> OwnedSlot::acquireOutput()
{
    out_ = FrameBuffer(in_.format(), in_.width(), in_.height());
    return out_.view();
}

// ---- external tools ---------------------------------------------------------------------

std::string shellQuote(const std::string &s)
{
    std::string q = "'";
    for (char c : s) {
        if (c == '\'')
            q += "'\\''";
        else
            q += c;
    }
    return q + "'";
}

bool haveCommand(const std::string &name)
{
    return std::system(("command -v " + shellQuote(name) + " >/dev/null 2>&1").c_str()) == 0;
}

bool ffmpegHasFilter(const std::string &filter)
{
    if (!haveCommand("ffmpeg"))
        return false;
    const std::string out = commandOutput("ffmpeg -hide_banner -filters 2>/dev/null");
    std::istringstream s(out);
    std::string line;
    while (std::getline(s, line)) {
        std::istringstream l(line);
        std::string flags, name;
        l >> flags >> name;
        if (name == filter)
            return true;
    }
    return false;
}

int runCommand(const std::string &command, double *seconds)
{
    const auto t0 = Clock::now();
    const int status = std::system(command.c_str());
    if (seconds)
        *seconds = secondsBetween(t0, Clock::now());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string commandOutput(const std::string &command)
{
    std::string out;
    std::FILE *p = ::popen(command.c_str(), "r");
    if (!p)
        return out;
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0)
        out.append(buf, n);
    ::pclose(p);
    return out;
}

ScratchDir::ScratchDir(const std::string &tag)
{
    struct stat st {};
    const std::string base = ::stat("/dev/shm", &st) == 0 && S_ISDIR(st.st_mode) ? "/dev/shm" : "/tmp";
    std::string templ = base + "/uavstab-bench-" + tag + "-XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    if (!::mkdtemp(buf.data()))
        throw std::runtime_error("cannot create scratch directory in " + base);
    path_ = buf.data();
}

ScratchDir::~ScratchDir()
{
    std::system(("rm -rf " + shellQuote(path_)).c_str());
}

void writeRawI420(std::FILE *f, const FrameView &frame)
{
    if (frame.format != PixelFormat::I420)
        throw std::invalid_argument("writeRawI420: not I420");
    for (int p = 0; p < 3; ++p)
        for (int y = 0; y < frame.planeHeight(p); ++y)
            std::fwrite(frame.planes[p].data + std::size_t(y) * frame.planes[p].stride, 1,
                        std::size_t(frame.planeWidth(p)), f);
}

bool readRawI420(std::FILE *f, FrameBuffer &frame, int width, int height)
{
    if (frame.format() != PixelFormat::I420 || frame.width() != width || frame.height() != height)
        frame = FrameBuffer(PixelFormat::I420, width, height);
    for (int p = 0; p < 3; ++p)
        for (int y = 0; y < frame.view().planeHeight(p); ++y) {
            const std::size_t n = std::size_t(frame.view().planeWidth(p));
            if (std::fread(frame.row(p, y), 1, n, f) != n)
                return false;
        }
    return true;
}

RawPipeReader::RawPipeReader(const std::string &command, int width, int height)
    : pipe_(::popen(command.c_str(), "r")), width_(width), height_(height)
{
    if (!pipe_)
        throw std::runtime_error("cannot run " + command);
}

RawPipeReader::~RawPipeReader()
{
    close();
}

bool RawPipeReader::read(FrameBuffer &frame)
{
    return pipe_ && readRawI420(pipe_, frame, width_, height_);
}

int RawPipeReader::close()
{
    if (!pipe_)
        return 0;
    // Drain so that the writer is not killed by SIGPIPE.
    char buf[65536];
    while (std::fread(buf, 1, sizeof buf, pipe_) > 0) {
    }
    const int status = ::pclose(pipe_);
    pipe_ = nullptr;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool probeVideo(const std::string &path, DecodedClip *clip)
{
    const std::string out = commandOutput("ffprobe -v error -select_streams v:0 -show_entries "
                                          "stream=width,height,avg_frame_rate -of csv=p=0 " +
                                          shellQuote(path) + " 2>/dev/null");
    int num = 0, den = 1;
    std::sscanf(out.c_str(), "%d,%d,%d/%d", &clip->width, &clip->height, &num, &den);
    if (clip->width <= 0 || clip->height <= 0)
        return false;
    clip->fps_num = num > 0 && den > 0 ? num : 30;
    clip->fps_den = num > 0 && den > 0 ? den : 1;
    return true;
}

bool decodeI420(const std::string &path, int max_frames, DecodedClip *clip)
{
    if (!probeVideo(path, clip))
        return false;
    RawPipeReader reader("ffmpeg -hide_banner -loglevel error -nostdin -i " + shellQuote(path) +
                             format(" -frames:v %d -fps_mode passthrough -f rawvideo -pix_fmt yuv420p -", max_frames),
                         clip->width, clip->height);
    uavstab::FrameBuffer frame;
    while (int(clip->frames.size()) < max_frames && reader.read(frame))
        clip->frames.push_back(frame);
    reader.close();
    return clip->frames.size() >= 10;
}

double psnrCentral(const cv::Mat &a, const cv::Mat &b)
{
    const cv::Rect r(int(a.cols * 0.2), int(a.rows * 0.2), int(a.cols * 0.6), int(a.rows * 0.6));
    cv::Mat diff;
    cv::absdiff(a(r), b(r), diff);
    diff.convertTo(diff, CV_64F);
    const double mse = cv::mean(diff.mul(diff))[0];
    return mse <= 1e-10 ? 100.0 : std::min(100.0, 10.0 * std::log10(255.0 * 255.0 / mse));
}

std::vector<std::string> realClipFiles(const std::string &dir)
{
    std::vector<std::string> files;
    if (DIR *d = opendir(dir.c_str())) {
        while (dirent *e = readdir(d)) {
            const std::string n = e->d_name;
            if (n.size() > 4 && (n.substr(n.size() - 4) == ".mp4" || n.substr(n.size() - 4) == ".avi"))
                files.push_back(n);
        }
        closedir(d);
    }
    std::sort(files.begin(), files.end());
    return files;
}

} // namespace bench
