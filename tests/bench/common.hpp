// Shared pieces of the benchmark programs: timing and statistics, process memory,
// result files (markdown fragments + a key/value summary), in-memory frame sets, a
// FrameSlot over a recycled output pool, ffmpeg helpers and raw-video I/O.
#pragma once

#include <chrono>
#include <ctime>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "uavstab/frame_buffer.hpp"
#include "uavstab/stabilizer.hpp"

namespace bench {

using Clock = std::chrono::steady_clock;
double secondsBetween(Clock::time_point a, Clock::time_point b);
double msBetween(Clock::time_point a, Clock::time_point b);

// ---- statistics -------------------------------------------------------------------
double median(std::vector<double> v);
// Linear interpolation between order statistics, p in [0, 100].
double percentile(std::vector<double> v, double p);
double mean(const std::vector<double> &v);
double minOf(const std::vector<double> &v);
double maxOf(const std::vector<double> &v);
// "median (min-max)" with the given printf format for each number.
std::string spread(const std::vector<double> &v, const char *number_format = "%.0f");

std::string format(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

// CPU seconds of a clock: CLOCK_PROCESS_CPUTIME_ID (every thread), CLOCK_THREAD_CPUTIME_ID.
double cpuSeconds(clockid_t clock);

// ---- process memory (Linux /proc) ----------------------------------------------------
long rssKiB();        // VmRSS
long peakRssKiB();    // VmHWM
bool resetPeakRss();  // writes 5 to /proc/self/clear_refs: VmHWM := VmRSS
long heapInUseKiB();  // malloc'ed bytes in use (mallinfo2: heap in use + mmapped chunks)

// CPU used by other processes (and stolen by the hypervisor) while a measurement ran:
// the machine is shared, so every section reports it beside its numbers.
class LoadMonitor {
public:
    LoadMonitor() { restart(); }
    void restart();
    // Shares of all CPUs' time since restart(): busy in other processes, and stolen.
    double foreignShare() const;
    double stealShare() const;
    std::string describe() const;

private:
    struct Sample {
        double busy = 0, steal = 0, own = 0;
        Clock::time_point time;
    };
    static Sample sample();
    Sample start_;
};

// Waits (up to max_seconds) until other processes use less than `share` of the CPUs,
// sampled over 1 s; returns false on timeout.
bool waitQuiet(double max_seconds = 120, double share = 0.15);

// Runs `measure` (one configuration's set of runs) until other processes took less than
// 15 % of the CPUs while it ran (at most 3 attempts, each after waitQuiet()): on a shared
// machine a burst of someone else's work would otherwise pass for our slowness.
// Returns the share other processes took during the accepted attempt.
double measureQuietly(const std::string &what, const std::function<void()> &measure);
// "3 %" for a table cell.
std::string loadCell(double share);

// ---- results ----------------------------------------------------------------------
// Command-line options every benchmark program takes.
struct Options {
    bool quick = false;
    std::string out_dir = ".";
    std::vector<std::string> only;  // sections to run (empty = all)
    std::string data_dir;           // real clips (../shared/data relative to the repo)
    std::vector<std::string> resolutions;  // --resolution WxH (repeatable): only these sizes
    std::vector<std::string> rest;  // the program's own flags (program_flags), each with its value
    bool wants(const std::string &section) const;
};
// Prints `usage` and exits on -h/--help. `--only` takes one of `sections`; each flag of
// `program_flags` takes a value and goes to Options::rest. Anything else throws with the usage.
Options parseOptions(int argc, char **argv, const char *usage, const std::vector<std::string> &sections = {},
                     const std::vector<std::string> &program_flags = {});

// Appends "key<TAB>value" lines to OUT/summary.tsv (read by the report assembler).
void putResult(const Options &o, const std::string &key, double value);
void putResultText(const Options &o, const std::string &key, const std::string &value);

// A markdown table, written to a fragment file.
class Table {
public:
    explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
    void row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
    bool empty() const { return rows_.empty(); }
    std::string markdown() const;

private:
    std::vector<std::string> header_;
    std::vector<std::vector<std::string>> rows_;
};

// Markdown fragment OUT/NAME.md, overwritten by each program run.
class Fragment {
public:
    Fragment(const Options &o, const std::string &name);
    ~Fragment();
    void text(const std::string &s);  // a paragraph (also echoed to stdout)
    void table(const Table &t);
    void line(const std::string &s);  // raw line, no echo

private:
    std::FILE *file_;
    LoadMonitor load_;
};

// ---- frames -----------------------------------------------------------------------
struct Resolution {
    int width, height;
    std::string name() const;
};
// The sizes a run covers: the standard set, or only those named by --resolution.
std::vector<Resolution> benchResolutions(const Options &o);

// How many frames each resolution gets in the speed runs.
struct ResolutionPlan {
    Resolution res;
    int distinct;     // frames rendered (then played back and forth)
    long pushes;      // frames per timed run
    int peer_frames;  // frames per ffmpeg run
};
ResolutionPlan planFor(const Resolution &r, bool quick);
std::vector<ResolutionPlan> benchPlans(const Options &o);
const char *formatName(uavstab::PixelFormat f);

// Frames of the synthetic shaky flight (two moving objects), rendered in memory (BGR).
std::vector<cv::Mat> renderFlight(int width, int height, int count, std::uint32_t seed = 7);
// A frame of the given format from a BGR picture (I420: BT.601 via OpenCV).
uavstab::FrameBuffer frameFromBgr(const cv::Mat &bgr, uavstab::PixelFormat format);
std::vector<uavstab::FrameBuffer> framesFromBgr(const std::vector<cv::Mat> &bgr, uavstab::PixelFormat format);
// Index of the k-th frame to push when a clip of n frames is played back and forth
// (0 1 .. n-1 n-2 .. 1 0 1 ..): endless input with continuous motion.
int pingPong(long k, int n);

// Output frames recycled the way a host's buffer pool would be.
class OutputPool {
public:
    OutputPool(uavstab::PixelFormat format, int width, int height) : format_(format), width_(width), height_(height) {}
    std::unique_ptr<uavstab::FrameBuffer> get();
    void put(std::unique_ptr<uavstab::FrameBuffer> b);
    std::size_t allocated() const { return allocated_; }

private:
    std::mutex mutex_;
    uavstab::PixelFormat format_;
    int width_, height_;
    std::vector<std::unique_ptr<uavstab::FrameBuffer>> free_;
    std::size_t allocated_ = 0;
};

// Reads a frame it does not own; writes into a pooled output, returned when destroyed.
class PoolSlot : public uavstab::FrameSlot {
public:
    PoolSlot(const uavstab::FrameView &in, OutputPool &pool, long index) : in_(in), pool_(pool), index_(index) {}
    ~PoolSlot() override;
    uavstab::FrameView input() override { return in_; }
    std::optional<uavstab::FrameView> acquireOutput() override;
    long index() const { return index_; }
    const uavstab::FrameBuffer *output() const { return out_.get(); }

private:
    uavstab::FrameView in_;
    OutputPool &pool_;
    long index_;
    std::unique_ptr<uavstab::FrameBuffer> out_;
};

// Owns its input (a private copy) and its output.
class OwnedSlot : public uavstab::FrameSlot {
public:
    OwnedSlot(uavstab::FrameBuffer in, long index) : in_(std::move(in)), index_(index) {}
    uavstab::FrameView input() override { return in_.view(); }
    std::optional<uavstab::FrameView> acquireOutput() override;
    long index() const { return index_; }
    const uavstab::FrameBuffer &in() const { return in_; }
    const uavstab::FrameBuffer &out() const { return out_; }

private:
    uavstab::FrameBuffer in_, out_;
    long index_;
};

// ---- external tools -----------------------------------------------------------------
bool haveCommand(const std::string &name);
// The video clips (.mp4, .avi) in `dir`, file names sorted; none when it cannot be read.
std::vector<std::string> realClipFiles(const std::string &dir);
bool ffmpegHasFilter(const std::string &filter);
// Runs a shell command; returns its exit status. Wall time in *seconds when given.
int runCommand(const std::string &command, double *seconds = nullptr);
std::string commandOutput(const std::string &command);
std::string shellQuote(const std::string &s);

// Scratch directory in tmpfs (/dev/shm when present), removed by the destructor.
class ScratchDir {
public:
    explicit ScratchDir(const std::string &tag);
    ~ScratchDir();
    const std::string &path() const { return path_; }
    std::string file(const std::string &name) const { return path_ + "/" + name; }

private:
    std::string path_;
};

// Raw I420 (yuv420p) files and pipes, frame by frame.
void writeRawI420(std::FILE *f, const uavstab::FrameView &frame);
bool readRawI420(std::FILE *f, uavstab::FrameBuffer &frame, int width, int height);

// Reads frames from a pipe (ffmpeg ... -f rawvideo -pix_fmt yuv420p -).
class RawPipeReader {
public:
    RawPipeReader(const std::string &command, int width, int height);
    ~RawPipeReader();
    bool read(uavstab::FrameBuffer &frame);
    int close();  // exit status

private:
    std::FILE *pipe_;
    int width_, height_;
};

// ---- real clips -----------------------------------------------------------------------
struct DecodedClip {
    int width = 0, height = 0, fps_num = 30, fps_den = 1;
    std::vector<uavstab::FrameBuffer> frames;  // I420
};
// A video file's size and frame rate (ffprobe), no frames; false when it cannot be read.
bool probeVideo(const std::string &path, DecodedClip *clip);
// The first max_frames frames of a video file, decoded by ffmpeg to I420 in memory; false
// when it cannot be read or has fewer than 10 frames.
bool decodeI420(const std::string &path, int max_frames, DecodedClip *clip);
// PSNR (dB) between two lumas over their central 60 %: the term of the ITF (inter-frame
// transformation fidelity) of consecutive output frames.
double psnrCentral(const cv::Mat &a, const cv::Mat &b);

} // namespace bench
