#include "estimate/luma_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "cpu_features.hpp"

#ifdef UAVSTAB_HAVE_X86
#include <immintrin.h>
#endif

namespace uavstab {

namespace {

// Output rows of a downscale by 3 per shared chunk (360 at 1080p and 4K: 12 chunks).
constexpr int kChunkRows = 30;

// round(sum / 9) for sums of nine 8-bit samples (at most 2295): (sum + 4) * 7282 >> 16 is
// exactly (sum + 4) / 9 over that range, so the vector and scalar paths agree.
inline std::uint8_t average9(unsigned sum)
{
    return std::uint8_t(((sum + 4u) * 7282u) >> 16);
}

#ifdef UAVSTAB_HAVE_X86

// The sums of the 3-pixel runs of one row for 16 outputs: lane L (outputs 8L .. 8L + 7)
// reads bytes 24L .. 24L + 23 of `r` as two overlapping 16-byte halves (q0 = bytes 0..15,
// q1 = 8..23 of the lane's). The first two pixels of each run are paired and added by
// maddubs, the third is zero-extended to 16 bits by its own shuffle.
__attribute__((target("avx2"))) inline __m256i runSumsAvx2(const std::uint8_t *r)
{
    const __m256i q0 = _mm256_loadu2_m128i(reinterpret_cast<const __m128i *>(r + 24),
                                           reinterpret_cast<const __m128i *>(r));
    const __m256i q1 = _mm256_loadu2_m128i(reinterpret_cast<const __m128i *>(r + 32),
                                           reinterpret_cast<const __m128i *>(r + 8));
    // Runs 0-4 of the lane lie in q0 (bytes 3j, 3j + 1, 3j + 2), runs 5-7 in q1 (8 bytes on).
    const __m256i pair0 = _mm256_setr_epi8(0, 1, 3, 4, 6, 7, 9, 10, 12, 13, -1, -1, -1, -1, -1, -1,  //
                                           0, 1, 3, 4, 6, 7, 9, 10, 12, 13, -1, -1, -1, -1, -1, -1);
    const __m256i pair1 = _mm256_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 7, 8, 10, 11, 13, 14,  //
                                           -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 7, 8, 10, 11, 13, 14);
    const __m256i third0 = _mm256_setr_epi8(2, -1, 5, -1, 8, -1, 11, -1, 14, -1, -1, -1, -1, -1, -1, -1,  //
                                            2, -1, 5, -1, 8, -1, 11, -1, 14, -1, -1, -1, -1, -1, -1, -1);
    const __m256i third1 = _mm256_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 9, -1, 12, -1, 15, -1,  //
                                            -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 9, -1, 12, -1, 15, -1);
    const __m256i pairs = _mm256_or_si256(_mm256_shuffle_epi8(q0, pair0), _mm256_shuffle_epi8(q1, pair1));
    const __m256i thirds = _mm256_or_si256(_mm256_shuffle_epi8(q0, third0), _mm256_shuffle_epi8(q1, third1));
    return _mm256_add_epi16(_mm256_maddubs_epi16(pairs, _mm256_set1_epi8(1)), thirds);
}

// One output row of a 1-channel image, 16 pixels at a time (returns how many it wrote): the
// run sums of the three source rows added (at most 2295), averaged, packed. Reads bytes
// up to 3 * o + 47 of each row for the last group: within the 3 * out_n bytes summed.
// `next` (bytes from r0 to the next output row's first source row, 0 for none): those
// three rows are asked for ahead, as the hardware prefetchers do not fetch them in time: a
// 1080p luma plane fresh from memory took 175-210 us before, 76-131 us with this and the
// run sums (in cache: 78 -> 62 us).
__attribute__((target("avx2"))) int boxRowAvx2(const std::uint8_t *r0, const std::uint8_t *r1, const std::uint8_t *r2,
                                               std::uint8_t *out, int out_n, std::ptrdiff_t next)
{
    int o = 0;
    for (; o + 16 <= out_n; o += 16) {
        if (next != 0 && o % 64 == 0)  // the 192 bytes of each row that 64 outputs read
            for (const std::uint8_t *row : {r0, r1, r2})
                for (int line = 0; line < 3; ++line)
                    _mm_prefetch(reinterpret_cast<const char *>(row + next + 3 * o + 64 * line), _MM_HINT_T0);
        const __m256i sum = _mm256_add_epi16(_mm256_add_epi16(runSumsAvx2(r0 + 3 * o), runSumsAvx2(r1 + 3 * o)),
                                             runSumsAvx2(r2 + 3 * o));
        const __m256i mean = _mm256_mulhi_epu16(_mm256_add_epi16(sum, _mm256_set1_epi16(4)), _mm256_set1_epi16(7282));
        // packus: [outputs 0-7 twice | 8-15 twice]; keep the first 64 bits of each lane.
        const __m256i packed = _mm256_permute4x64_epi64(_mm256_packus_epi16(mean, mean), 0x08);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(out + o), _mm256_castsi256_si128(packed));
    }
    return o;
}

#endif // UAVSTAB_HAVE_X86

} // namespace

void boxDownscale3(const cv::Mat &src, cv::Mat &dst, std::vector<std::uint16_t> &row_sums)
{
    CV_Assert(src.depth() == CV_8U && (src.channels() == 1 || src.channels() == 4));
    const int channels = src.channels();
    const int width = src.cols / 3, height = src.rows / 3;
    dst.create(height, width, src.type());
    const int n = width * 3 * channels;  // source bytes summed per row
    const int out_n = width * channels;  // output bytes per row
    row_sums.resize(std::size_t(n) + 32);
    std::uint16_t *sums = row_sums.data();
    for (int y = 0; y < height; ++y) {
        const std::uint8_t *r0 = src.ptr<std::uint8_t>(3 * y), *r1 = src.ptr<std::uint8_t>(3 * y + 1),
                           *r2 = src.ptr<std::uint8_t>(3 * y + 2);
        std::uint8_t *out = dst.ptr<std::uint8_t>(y);
        // Bytes from r0 to the next output row's first source row (0: none), prefetched.
        const std::ptrdiff_t next = y + 1 < height ? 3 * std::ptrdiff_t(src.step[0]) : 0;
#ifdef UAVSTAB_HAVE_X86
        if (channels == 1 && cpuHasAvx2()) {
            for (int o = boxRowAvx2(r0, r1, r2, out, out_n, next); o < out_n; ++o)
                out[o] = average9(unsigned(r0[3 * o]) + r0[3 * o + 1] + r0[3 * o + 2] + r1[3 * o] + r1[3 * o + 1] +
                                  r1[3 * o + 2] + r2[3 * o] + r2[3 * o + 1] + r2[3 * o + 2]);
            continue;
        }
#endif
        int i = 0;
#if CV_SIMD128
        for (; i + 16 <= n; i += 16) {
            // As boxRowAvx2: a 1080p BGRx frame fresh from memory 666-706 -> 552-596 us.
            if (next != 0 && i % 64 == 0)
                for (const std::uint8_t *row : {r0, r1, r2})
                    __builtin_prefetch(row + next + i);
            cv::v_uint16x8 a0, a1, b0, b1, c0, c1;
            cv::v_expand(cv::v_load(r0 + i), a0, a1);
            cv::v_expand(cv::v_load(r1 + i), b0, b1);
            cv::v_expand(cv::v_load(r2 + i), c0, c1);
            cv::v_store(sums + i, a0 + b0 + c0);
            cv::v_store(sums + i + 8, a1 + b1 + c1);
        }
#endif
        for (; i < n; ++i)
            sums[i] = std::uint16_t(r0[i] + r1[i] + r2[i]);
        int o = 0;
#if CV_SIMD128
        const cv::v_uint16x8 bias = cv::v_setall_u16(4), scale = cv::v_setall_u16(7282);
        if (channels == 1) {
            for (; o + 16 <= out_n; o += 16) {
                cv::v_uint16x8 a, b, c, d, e, f;
                cv::v_load_deinterleave(sums + 3 * o, a, b, c);
                cv::v_load_deinterleave(sums + 3 * o + 24, d, e, f);
                cv::v_store(out + o, cv::v_pack(cv::v_mul_hi(a + b + c + bias, scale),
                                                 cv::v_mul_hi(d + e + f + bias, scale)));
            }
        } else {
            // A pixel's four 16-bit sums are one 64-bit lane.
            const auto *lanes = reinterpret_cast<const uint64 *>(sums);
            for (; o + 16 <= out_n; o += 16) {
                cv::v_uint64x2 a, b, c, d, e, f;
                cv::v_load_deinterleave(lanes + 3 * (o / 4), a, b, c);
                cv::v_load_deinterleave(lanes + 3 * (o / 4) + 6, d, e, f);
                const cv::v_uint16x8 lo = cv::v_reinterpret_as_u16(a) + cv::v_reinterpret_as_u16(b) +
                                          cv::v_reinterpret_as_u16(c) + bias;
                const cv::v_uint16x8 hi = cv::v_reinterpret_as_u16(d) + cv::v_reinterpret_as_u16(e) +
                                          cv::v_reinterpret_as_u16(f) + bias;
                cv::v_store(out + o, cv::v_pack(cv::v_mul_hi(lo, scale), cv::v_mul_hi(hi, scale)));
            }
        }
#endif
        for (; o < out_n; ++o) {
            const int x = o / channels, ch = o % channels;
            const std::uint16_t *s = sums + 3 * x * channels + ch;
            out[o] = average9(unsigned(s[0]) + s[channels] + s[2 * channels]);
        }
    }
}

cv::Mat planeMat(const FrameView &frame, int plane)
{
    // (16-bit: the stride must be even, as cv::Mat requires; see LumaExtractor::extract16.)
    const PlaneLayout layout = planeLayout(frame.format, plane);
    const int depth = layout.bytes_per_sample == 2 ? CV_16U : CV_8U;
    return cv::Mat(frame.planeHeight(plane), frame.planeWidth(plane), CV_MAKETYPE(depth, layout.channels),
                   frame.planes[plane].data, std::size_t(frame.planes[plane].stride));
}

bool needsByteSwap(PixelFormat format)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    return format == PixelFormat::Gray16LE;
#else
    return format == PixelFormat::Gray16BE;
#endif
}

AutoGain::Limits AutoGain::update(const cv::Mat &image)
{
    CV_Assert(image.type() == CV_16UC1 && !image.empty());
    // A regular grid of about kSampleTarget pixels (every pixel of a small image).
    const double area = double(image.rows) * image.cols;
    const int step = std::max(1, int(std::floor(std::sqrt(area / kSampleTarget))));
    samples_.clear();
    // (Starting inside the image even when it is thinner than a step.)
    for (int y = std::min(step / 2, image.rows - 1); y < image.rows; y += step) {
        const std::uint16_t *row = image.ptr<std::uint16_t>(y);
        for (int x = std::min(step / 2, image.cols - 1); x < image.cols; x += step)
            samples_.push_back(row[x]);
    }
    const std::size_t n = samples_.size();
    const auto rank = [n](double q) { return std::min(n - 1, std::size_t(std::lround(q * double(n - 1)))); };
    const std::size_t low_rank = rank(kLowPercentile), high_rank = rank(kHighPercentile);
    std::nth_element(samples_.begin(), samples_.begin() + std::ptrdiff_t(high_rank), samples_.end());
    const double high = samples_[high_rank];
    std::nth_element(samples_.begin(), samples_.begin() + std::ptrdiff_t(low_rank),
                     samples_.begin() + std::ptrdiff_t(high_rank));
    const double low = samples_[low_rank];
    measurement_.percentiles = {low, high};

    const auto withMinSpan = [](Limits l) {
        if (l.high - l.low < kMinSpan) {
            const double centre = 0.5 * (l.low + l.high);
            l = {centre - 0.5 * kMinSpan, centre + 0.5 * kMinSpan};
        }
        return l;
    };
    if (!initialized_) {
        limits_ = withMinSpan(measurement_.percentiles);
        measurement_.clipped_share = 0.0;
        initialized_ = true;
        return limits_;
    }

    std::size_t clipped = 0;
    for (const std::uint16_t v : samples_)
        clipped += v < limits_.low || v > limits_.high;
    measurement_.clipped_share = double(clipped) / double(n);

    const double span = limits_.high - limits_.low;
    const bool lost = measurement_.clipped_share > kLostShare;
    const auto follow = [&](double current, double measured) {
        const double error = measured - current;
        if (lost)
            return current + kFastFollow * error;
        if (std::abs(error) <= kDeadBand * span)
            return current;  // hysteresis: the same mapping as the previous frame
        const double limit = kMaxRate * span;
        return current + std::clamp(kFollow * error, -limit, limit);
    };
    limits_ = withMinSpan({follow(limits_.low, low), follow(limits_.high, high)});
    return limits_;
}

void LumaExtractor::downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size)
{
    // OpenCV's area resampling is fast for an exact halving and slow for other factors
    // (1080p -> 640: 0.84 ms, against 0.06 ms for 1920 -> 960). So halve while the
    // result stays at least the target size, then bilinear for the last factor (< 2,
    // where bilinear still reads every source pixel).
    // An exact factor of 3 times a power of two (1080p -> 640x360, 4K -> 640x360): halve
    // exactly, then average 3x3 blocks (0.1 ms at 1080p, against 0.4 ms for a halving and
    // a bilinear 1.5).
    int factor = src.cols / std::max(size.width, 1);
    const bool box3 = (src.depth() == CV_8U && (src.channels() == 1 || src.channels() == 4)) &&
                      factor >= 3 && src.cols == factor * size.width && src.rows == factor * size.height &&
                      factor % 3 == 0 && ((factor / 3) & (factor / 3 - 1)) == 0;
    const cv::Mat *level = &src;
    std::size_t k = 0;
    if (box3) {
        for (; factor > 3; factor /= 2) {
            if (halvings_.size() <= k)
                halvings_.emplace_back();
            cv::resize(*level, halvings_[k], cv::Size(level->cols / 2, level->rows / 2), 0, 0, cv::INTER_AREA);
            level = &halvings_[k++];
        }
        // Bands of rows from their own source rows into their own output rows: the same
        // bytes whoever runs them.
        const int rows = level->rows / 3;
        dst.create(rows, level->cols / 3, level->type());
        runShared(share_, (rows + kChunkRows - 1) / kChunkRows, [&](int chunk, int lane) {
            const int begin = chunk * kChunkRows, end = std::min(rows, begin + kChunkRows);
            cv::Mat out = dst.rowRange(begin, end);
            boxDownscale3(level->rowRange(3 * begin, 3 * end), out, row_sums_[lane]);
        });
        return;
    }
    while (level->cols / 2 >= size.width && level->rows / 2 >= size.height) {
        if (halvings_.size() <= k)
            halvings_.emplace_back();
        cv::resize(*level, halvings_[k], cv::Size(level->cols / 2, level->rows / 2), 0, 0, cv::INTER_AREA);
        level = &halvings_[k++];
    }
    if (level->size() == size)
        level->copyTo(dst);
    else
        cv::resize(*level, dst, size, 0, 0, cv::INTER_LINEAR);
}

cv::Size LumaExtractor::analysisSize(int width, int height, int analysis_width)
{
    const int w = std::min(width, std::max(analysis_width, 1));
    const int h = std::max(1, int(std::lround(double(height) * w / width)));
    return {w, w == width ? height : h};
}

const cv::Mat &LumaExtractor::extract16(const FrameView &frame, cv::Size size)
{
    const Plane &plane = frame.planes[0];
    const bool swap = needsByteSwap(frame.format);
    const bool aligned =
        plane.stride % 2 == 0 && reinterpret_cast<std::uintptr_t>(plane.data) % alignof(std::uint16_t) == 0;
    cv::Mat samples;
    if (swap || !aligned) {
        // Samples in the other byte order, or not at 16-bit boundaries (an odd stride):
        // copied once, in host order, to an aligned image.
        swapped_.create(frame.height, frame.width, CV_16UC1);
        for (int y = 0; y < frame.height; ++y) {
            const std::uint8_t *in = plane.data + std::size_t(y) * std::size_t(plane.stride);
            std::uint16_t *out = swapped_.ptr<std::uint16_t>(y);
            std::memcpy(out, in, std::size_t(frame.width) * 2);
            if (swap)
                for (int x = 0; x < frame.width; ++x)
                    out[x] = std::uint16_t((out[x] >> 8) | (out[x] << 8));
        }
        samples = swapped_;
    } else {
        samples = planeMat(frame, 0);
    }
    if (samples.size() != size) {
        downscale(samples, luma16_, size);
        samples = luma16_;
    }
    // The gain is measured and moved on this frame, then maps it to 8 bits (rounded,
    // saturated at both ends).
    const AutoGain::Limits limits = gain_.update(samples);
    const double gain = 255.0 / (limits.high - limits.low);
    samples.convertTo(luma_, CV_8U, gain, -limits.low * gain);
    return luma_;
}

const cv::Mat &LumaExtractor::extract(const FrameView &frame, int analysis_width)
{
    if (!frame.valid())
        throw std::invalid_argument("LumaExtractor: invalid frame");
    const cv::Size size = analysisSize(frame.width, frame.height, analysis_width);
    if (is16Bit(frame.format))
        return extract16(frame, size);
    const bool resample = size.width != frame.width || size.height != frame.height;
    const cv::Mat packed = planeMat(frame, 0);

    if (isYuv(frame.format) || frame.format == PixelFormat::Gray8) {
        if (!resample) {
            view_ = packed;  // the Y plane itself; the caller copies what it keeps
            return view_;
        }
        downscale(packed, luma_, size);
        return luma_;
    }

    // Packed RGB: shrink first (fewer pixels to convert), then convert once.
    const RgbOrder order = rgbOrder(frame.format);
    const bool bgr = order.b == 0;
    const int channels = planeLayout(frame.format, 0).channels;
    const int code = channels == 3 ? (bgr ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY)
                                   : (bgr ? cv::COLOR_BGRA2GRAY : cv::COLOR_RGBA2GRAY);
    if (resample) {
        downscale(packed, packed_small_, size);
        cv::cvtColor(packed_small_, luma_, code);
    } else {
        cv::cvtColor(packed, luma_, code);
    }
    return luma_;
}

} // namespace uavstab
