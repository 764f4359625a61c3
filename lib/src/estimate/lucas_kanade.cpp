#include "estimate/lucas_kanade.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <opencv2/video/tracking.hpp>

#include "estimate/scharr_derivatives.hpp"

#include "cpu_features.hpp"

#ifdef UAVSTAB_HAVE_X86
#include <immintrin.h>
#endif

namespace uavstab {

namespace {

// Fixed-point sampling as OpenCV's: bilinear weights in 1/2^14, the image windows kept as
// 32 x grey level, derivatives as they are; the window sums scaled by 2^-20.
constexpr int kWeightBits = 14;
constexpr int kImageShift = kWeightBits - 5;
constexpr float kSumScale = 1.f / (1 << 20);
constexpr int kLanes = 8;

inline int descale(int value, int bits)
{
    return (value + (1 << (bits - 1))) >> bits;
}

struct Weights {
    int w00, w01, w10, w11;
};

inline Weights weightsAt(cv::Point2f p, cv::Point2i ip)
{
    const float a = p.x - float(ip.x), b = p.y - float(ip.y);
    Weights w;
    w.w00 = cvRound((1.f - a) * (1.f - b) * (1 << kWeightBits));
    w.w01 = cvRound(a * (1.f - b) * (1 << kWeightBits));
    w.w10 = cvRound((1.f - a) * b * (1 << kWeightBits));
    w.w11 = (1 << kWeightBits) - w.w00 - w.w01 - w.w10;
    return w;
}

// Per-lane partial sums: lane l takes the window's columns l, l + 8, l + 16... so that the
// scalar and AVX2 kernels add the same numbers in the same order.
struct LaneSums {
    float v[kLanes] = {};
    float total() const
    {
        float s = 0.f;
        for (float x : v)
            s += x;
        return s;
    }
};

// The previous image's window around a point: 32 x grey level and the derivatives per
// pixel, rows of `chunks * 8` lanes (lanes past the window's width: zero derivatives).
// `deriv`: the image derivatives of the pixels the window's samples read (its width and
// height plus one, and the vector kernel's spare lanes), interleaved (dx, dy).
struct Window {
    int width = 0, height = 0, chunks = 0;
    std::vector<std::int32_t> image;
    std::vector<float> dx, dy;
    float a11 = 0.f, a12 = 0.f, a22 = 0.f;
    std::vector<std::int16_t> deriv;
    std::size_t deriv_step = 0;  // int16 per row

    void resize(cv::Size size)
    {
        width = size.width;
        height = size.height;
        chunks = (width + kLanes - 1) / kLanes;
        const std::size_t n = std::size_t(height) * std::size_t(chunks) * kLanes;
        image.assign(n, 0);
        dx.assign(n, 0.f);
        dy.assign(n, 0.f);
        deriv_step = 2 * std::size_t(derivRegion().width) + 16;
        deriv.assign(deriv_step * std::size_t(height + 1), 0);
    }
    cv::Size derivRegion() const { return {chunks * kLanes + 1, height + 1}; }
    std::size_t rowOffset(int y) const { return std::size_t(y) * std::size_t(chunks) * kLanes; }
};

// Row y, column x of an 8-bit pyramid level; either may lie in the level's border, so
// negative. Signed arithmetic: Mat::ptr's unsigned offset wraps for a negative row.
inline const std::uint8_t *pixelAt(const cv::Mat &m, int y, int x)
{
    return m.data + std::ptrdiff_t(y) * std::ptrdiff_t(m.step[0]) + x;
}

// Whether every byte a vector kernel reads for a window at `ip` (rows ip.y .. ip.y + height,
// columns ip.x .. ip.x + chunks * 8, the last lanes past the window included) lies in the
// pyramid level's allocation. The scalar kernel reads only what OpenCV reads.
inline bool vectorReadsFit(const cv::Mat &m, cv::Point2i ip, const Window &w)
{
    const std::size_t pixel = m.elemSize();
    // As integers: a pointer formed outside the allocation would itself be undefined.
    const auto base = std::intptr_t(m.data);
    const std::intptr_t first = base + std::intptr_t(ip.y) * std::intptr_t(m.step[0]) + std::intptr_t(ip.x) * std::intptr_t(pixel);
    const std::intptr_t last = base + std::intptr_t(ip.y + w.height) * std::intptr_t(m.step[0]) +
                               std::intptr_t(ip.x + w.chunks * kLanes + 1) * std::intptr_t(pixel);
    return first >= std::intptr_t(m.datastart) && last <= std::intptr_t(m.dataend);
}

// --- Scalar kernel: the reference. ---

void sampleWindowScalar(const cv::Mat &image, cv::Point2i ip, const Weights &w, Window &win)
{
    const std::size_t image_step = image.step[0];
    const std::size_t deriv_step = win.deriv_step;
    LaneSums a11, a12, a22;
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(image, ip.y + y, ip.x);
        const std::int16_t *dsrc = win.deriv.data() + std::size_t(y) * deriv_step;
        const std::size_t row = win.rowOffset(y);
        for (int x = 0; x < win.width; ++x) {
            const int ival = descale(src[x] * w.w00 + src[x + 1] * w.w01 + src[x + image_step] * w.w10 +
                                         src[x + image_step + 1] * w.w11,
                                     kImageShift);
            const std::int16_t *d = dsrc + 2 * x;
            const int ixval = descale(d[0] * w.w00 + d[2] * w.w01 + d[deriv_step] * w.w10 + d[deriv_step + 2] * w.w11,
                                      kWeightBits);
            const int iyval = descale(d[1] * w.w00 + d[3] * w.w01 + d[deriv_step + 1] * w.w10 +
                                          d[deriv_step + 3] * w.w11,
                                      kWeightBits);
            const float fx = float(ixval), fy = float(iyval);
            win.image[row + std::size_t(x)] = ival;
            win.dx[row + std::size_t(x)] = fx;
            win.dy[row + std::size_t(x)] = fy;
            const int lane = x % kLanes;
            a11.v[lane] += fx * fx;
            a12.v[lane] += fx * fy;
            a22.v[lane] += fy * fy;
        }
    }
    win.a11 = a11.total();
    win.a12 = a12.total();
    win.a22 = a22.total();
}

inline int sampleNext(const std::uint8_t *src, std::size_t step, const Weights &w)
{
    return descale(src[0] * w.w00 + src[1] * w.w01 + src[step] * w.w10 + src[step + 1] * w.w11, kImageShift);
}

void residualScalar(const cv::Mat &next, cv::Point2i ip, const Weights &w, const Window &win, float &b1, float &b2)
{
    const std::size_t step = next.step[0];
    LaneSums s1, s2;
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(next, ip.y + y, ip.x);
        const std::size_t row = win.rowOffset(y);
        for (int x = 0; x < win.width; ++x) {
            const float diff = float(sampleNext(src + x, step, w) - win.image[row + std::size_t(x)]);
            s1.v[x % kLanes] += diff * win.dx[row + std::size_t(x)];
            s2.v[x % kLanes] += diff * win.dy[row + std::size_t(x)];
        }
    }
    b1 = s1.total();
    b2 = s2.total();
}

float absoluteDifferenceScalar(const cv::Mat &next, cv::Point2i ip, const Weights &w, const Window &win)
{
    const std::size_t step = next.step[0];
    LaneSums s;
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(next, ip.y + y, ip.x);
        const std::size_t row = win.rowOffset(y);
        for (int x = 0; x < win.width; ++x)
            s.v[x % kLanes] += float(std::abs(sampleNext(src + x, step, w) - win.image[row + std::size_t(x)]));
    }
    return s.total();
}

// --- AVX2 kernel: eight window columns at a time, the same integer maths and float sums. ---

#ifdef UAVSTAB_HAVE_X86

__attribute__((target("avx2"))) inline __m256i packedWeights(int left, int right)
{
    return _mm256_set1_epi32(int((std::uint32_t(right) << 16) | (std::uint32_t(left) & 0xffffu)));
}

// Bytes p[0..7] paired with their right neighbours, as 16-bit lanes (p0, p1, p1, p2, ...).
__attribute__((target("avx2"))) inline __m256i bytePairs(const std::uint8_t *p)
{
    const __m128i a = _mm_loadl_epi64(reinterpret_cast<const __m128i *>(p));
    const __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i *>(p + 1));
    return _mm256_cvtepu8_epi16(_mm_unpacklo_epi8(a, b));
}

// Eight bilinear samples of an 8-bit image (32 x grey level), columns x .. x + 7.
__attribute__((target("avx2"))) inline __m256i sampleImage8(const std::uint8_t *top, std::size_t step, __m256i w_top,
                                                             __m256i w_bottom)
{
    const __m256i sum = _mm256_add_epi32(_mm256_madd_epi16(bytePairs(top), w_top),
                                         _mm256_madd_epi16(bytePairs(top + step), w_bottom));
    return _mm256_srai_epi32(_mm256_add_epi32(sum, _mm256_set1_epi32(1 << (kImageShift - 1))), kImageShift);
}

__attribute__((target("avx2"))) inline float laneTotal(__m256 v)
{
    LaneSums s;
    _mm256_storeu_ps(s.v, v);
    return s.total();
}

__attribute__((target("avx2"))) inline __m256 lastChunkMask(const Window &win, int chunk)
{
    const int valid = std::min(kLanes, win.width - chunk * kLanes);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(valid), lane));
}

__attribute__((target("avx2"))) void sampleWindowAvx2(const cv::Mat &image, cv::Point2i ip, const Weights &w,
                                                      Window &win)
{
    const std::size_t image_step = image.step[0];
    const std::size_t deriv_step = win.deriv_step;
    const __m256i w_top = packedWeights(w.w00, w.w01), w_bottom = packedWeights(w.w10, w.w11);
    const __m256i round_deriv = _mm256_set1_epi32(1 << (kWeightBits - 1));
    const int last = win.chunks - 1;
    const __m256 last_mask = lastChunkMask(win, last);
    __m256 a11 = _mm256_setzero_ps(), a12 = _mm256_setzero_ps(), a22 = _mm256_setzero_ps();
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(image, ip.y + y, ip.x);
        const std::int16_t *dsrc = win.deriv.data() + std::size_t(y) * deriv_step;
        const std::size_t row = win.rowOffset(y);
        for (int k = 0; k < win.chunks; ++k) {
            const int x = k * kLanes;
            _mm256_storeu_si256(reinterpret_cast<__m256i *>(&win.image[row + std::size_t(x)]),
                                sampleImage8(src + x, image_step, w_top, w_bottom));
            // Derivative pairs (dx, dy) of columns x .. x + 7 and, one pixel on, x + 1 .. x + 8:
            // interleaved, each 16-bit pair of left and right taps meets its two weights.
            const std::int16_t *d = dsrc + 2 * x;
            const __m256i t0 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(d));
            const __m256i t1 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(d + 2));
            const __m256i b0 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(d + deriv_step));
            const __m256i b1 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(d + deriv_step + 2));
            // Lanes (dx, dy) of columns 0, 1 | 4, 5 and 2, 3 | 6, 7.
            __m256i lo = _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpacklo_epi16(t0, t1), w_top),
                                          _mm256_madd_epi16(_mm256_unpacklo_epi16(b0, b1), w_bottom));
            __m256i hi = _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpackhi_epi16(t0, t1), w_top),
                                          _mm256_madd_epi16(_mm256_unpackhi_epi16(b0, b1), w_bottom));
            lo = _mm256_srai_epi32(_mm256_add_epi32(lo, round_deriv), kWeightBits);
            hi = _mm256_srai_epi32(_mm256_add_epi32(hi, round_deriv), kWeightBits);
            const __m256 flo = _mm256_cvtepi32_ps(lo), fhi = _mm256_cvtepi32_ps(hi);
            __m256 fx = _mm256_shuffle_ps(flo, fhi, 0x88), fy = _mm256_shuffle_ps(flo, fhi, 0xdd);
            if (k == last) {
                fx = _mm256_and_ps(fx, last_mask);
                fy = _mm256_and_ps(fy, last_mask);
            }
            _mm256_storeu_ps(&win.dx[row + std::size_t(x)], fx);
            _mm256_storeu_ps(&win.dy[row + std::size_t(x)], fy);
            a11 = _mm256_add_ps(a11, _mm256_mul_ps(fx, fx));
            a12 = _mm256_add_ps(a12, _mm256_mul_ps(fx, fy));
            a22 = _mm256_add_ps(a22, _mm256_mul_ps(fy, fy));
        }
    }
    win.a11 = laneTotal(a11);
    win.a12 = laneTotal(a12);
    win.a22 = laneTotal(a22);
}

__attribute__((target("avx2"))) void residualAvx2(const cv::Mat &next, cv::Point2i ip, const Weights &w,
                                                  const Window &win, float &b1, float &b2)
{
    const std::size_t step = next.step[0];
    const __m256i w_top = packedWeights(w.w00, w.w01), w_bottom = packedWeights(w.w10, w.w11);
    __m256 s1 = _mm256_setzero_ps(), s2 = _mm256_setzero_ps();
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(next, ip.y + y, ip.x);
        const std::size_t row = win.rowOffset(y);
        for (int k = 0; k < win.chunks; ++k) {
            const int x = k * kLanes;
            const __m256i prev = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(&win.image[row + std::size_t(x)]));
            const __m256 diff =
                _mm256_cvtepi32_ps(_mm256_sub_epi32(sampleImage8(src + x, step, w_top, w_bottom), prev));
            s1 = _mm256_add_ps(s1, _mm256_mul_ps(diff, _mm256_loadu_ps(&win.dx[row + std::size_t(x)])));
            s2 = _mm256_add_ps(s2, _mm256_mul_ps(diff, _mm256_loadu_ps(&win.dy[row + std::size_t(x)])));
        }
    }
    b1 = laneTotal(s1);
    b2 = laneTotal(s2);
}

__attribute__((target("avx2"))) float absoluteDifferenceAvx2(const cv::Mat &next, cv::Point2i ip, const Weights &w,
                                                             const Window &win)
{
    const std::size_t step = next.step[0];
    const __m256i w_top = packedWeights(w.w00, w.w01), w_bottom = packedWeights(w.w10, w.w11);
    const int last = win.chunks - 1;
    const __m256 last_mask = lastChunkMask(win, last);
    __m256 s = _mm256_setzero_ps();
    for (int y = 0; y < win.height; ++y) {
        const std::uint8_t *src = pixelAt(next, ip.y + y, ip.x);
        const std::size_t row = win.rowOffset(y);
        for (int k = 0; k < win.chunks; ++k) {
            const int x = k * kLanes;
            const __m256i prev = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(&win.image[row + std::size_t(x)]));
            __m256 diff = _mm256_cvtepi32_ps(
                _mm256_abs_epi32(_mm256_sub_epi32(sampleImage8(src + x, step, w_top, w_bottom), prev)));
            if (k == last)
                diff = _mm256_and_ps(diff, last_mask);
            s = _mm256_add_ps(s, diff);
        }
    }
    return laneTotal(s);
}

#endif // UAVSTAB_HAVE_X86

struct Kernels {
    bool vector = false;

    void sampleWindow(const cv::Mat &image, cv::Point2i ip, const Weights &w, Window &win) const
    {
        scharrRegion(image, ip, win.derivRegion(), win.deriv.data(), win.deriv_step, vector);
#ifdef UAVSTAB_HAVE_X86
        if (vector && vectorReadsFit(image, ip, win))
            return sampleWindowAvx2(image, ip, w, win);
#endif
        sampleWindowScalar(image, ip, w, win);
    }
    void residual(const cv::Mat &next, cv::Point2i ip, const Weights &w, const Window &win, float &b1, float &b2) const
    {
#ifdef UAVSTAB_HAVE_X86
        if (vector && vectorReadsFit(next, ip, win))
            return residualAvx2(next, ip, w, win, b1, b2);
#endif
        residualScalar(next, ip, w, win, b1, b2);
    }
    float absoluteDifference(const cv::Mat &next, cv::Point2i ip, const Weights &w, const Window &win) const
    {
#ifdef UAVSTAB_HAVE_X86
        if (vector && vectorReadsFit(next, ip, win))
            return absoluteDifferenceAvx2(next, ip, w, win);
#endif
        return absoluteDifferenceScalar(next, ip, w, win);
    }
};

inline cv::Point2i floorPoint(cv::Point2f p)
{
    return {cvFloor(p.x), cvFloor(p.y)};
}

inline bool outside(cv::Point2i ip, cv::Size window, const cv::Mat &m)
{
    return ip.x < -window.width || ip.x >= m.cols || ip.y < -window.height || ip.y >= m.rows;
}

// One point through the pyramid, as cv::calcOpticalFlowPyrLK's LKTrackerInvoker.
void trackPoint(const LucasKanadePyramid &previous, const LucasKanadePyramid &next, cv::Point2f from,
                cv::Point2f &to, std::uint8_t &status, float *error, int max_level, const LucasKanadeParams &p,
                double epsilon2, const Kernels &kernels, Window &win)
{
    const cv::Point2f half_window((p.window.width - 1) * 0.5f, (p.window.height - 1) * 0.5f);
    status = 1;
    for (int level = max_level; level >= 0; --level) {
        const cv::Mat &image = previous.image(level);
        const cv::Mat &next_image = next.image(level);
        cv::Point2f prev_pt = from * float(1. / (1 << level));
        cv::Point2f next_pt = level == max_level ? prev_pt : to * 2.f;
        to = next_pt;

        prev_pt -= half_window;
        const cv::Point2i ip = floorPoint(prev_pt);
        if (outside(ip, p.window, image)) {
            if (level == 0) {
                status = 0;
                if (error != nullptr)
                    *error = 0.f;
            }
            continue;
        }
        kernels.sampleWindow(image, ip, weightsAt(prev_pt, ip), win);
        const float a11 = win.a11 * kSumScale, a12 = win.a12 * kSumScale, a22 = win.a22 * kSumScale;
        float det = a11 * a22 - a12 * a12;
        const float min_eigen = (a22 + a11 - std::sqrt((a11 - a22) * (a11 - a22) + 4.f * a12 * a12)) /
                                float(2 * p.window.width * p.window.height);
        if (min_eigen < p.min_eigen_threshold || det < FLT_EPSILON) {
            if (level == 0)
                status = 0;
            continue;
        }
        det = 1.f / det;

        next_pt -= half_window;
        cv::Point2f previous_delta;
        for (int j = 0; j < p.max_iterations; ++j) {
            const cv::Point2i in = floorPoint(next_pt);
            if (outside(in, p.window, next_image)) {
                if (level == 0)
                    status = 0;
                break;
            }
            float b1 = 0.f, b2 = 0.f;
            kernels.residual(next_image, in, weightsAt(next_pt, in), win, b1, b2);
            b1 *= kSumScale;
            b2 *= kSumScale;
            const cv::Point2f delta(float((a12 * b2 - a22 * b1) * det), float((a12 * b1 - a11 * b2) * det));
            next_pt += delta;
            to = next_pt + half_window;
            if (delta.ddot(delta) <= epsilon2)
                break;
            if (j > 0 && std::abs(delta.x + previous_delta.x) < 0.01f && std::abs(delta.y + previous_delta.y) < 0.01f) {
                to -= delta * 0.5f;  // oscillating between two positions: take the middle
                break;
            }
            previous_delta = delta;
        }

        if (status && error != nullptr && level == 0) {
            const cv::Point2f final_pt = to - half_window;
            const cv::Point2i in = floorPoint(final_pt);
            if (outside(in, p.window, next_image)) {
                status = 0;
                continue;
            }
            *error = kernels.absoluteDifference(next_image, in, weightsAt(final_pt, in), win) /
                     float(32 * p.window.width * p.window.height);
        }
    }
}

} // namespace

bool lucasKanadeRunsAvx2()
{
    static const bool chosen = [] {
#ifdef UAVSTAB_HAVE_X86
        bool avx2 = cpuHasAvx2();
#else
        bool avx2 = false;
#endif
        const char *env = std::getenv("UAVSTAB_LK_KERNEL");
        if (env != nullptr && std::strcmp(env, "opencv") == 0)
            avx2 = false;
        else if (env != nullptr && *env != '\0' && std::strcmp(env, "avx2") != 0)
            std::fprintf(stderr, "uavstab: UAVSTAB_LK_KERNEL=%s is not one of avx2, opencv: ignored\n", env);
        return avx2;
    }();
    return chosen;
}

void buildLucasKanadePyramid(const cv::Mat &image, LucasKanadePyramid &pyramid, cv::Size window, int max_level)
{
    pyramid.derivatives = !lucasKanadeRunsAvx2();
    cv::buildOpticalFlowPyramid(image, pyramid.levels, window, max_level, pyramid.derivatives, cv::BORDER_REFLECT_101,
                                cv::BORDER_CONSTANT, false);
}

void trackLucasKanade(const LucasKanadePyramid &previous, const LucasKanadePyramid &next,
                      const std::vector<cv::Point2f> &from, std::vector<cv::Point2f> &to,
                      std::vector<std::uint8_t> &status, std::vector<float> *errors, const LucasKanadeParams &params,
                      LucasKanadeKernel kernel)
{
    if (kernel == LucasKanadeKernel::OpenCv || (kernel == LucasKanadeKernel::Best && !lucasKanadeRunsAvx2())) {
        const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, params.max_iterations,
                                        params.epsilon);
        if (errors != nullptr)
            cv::calcOpticalFlowPyrLK(previous.levels, next.levels, from, to, status, *errors, params.window,
                                     params.max_level, criteria, 0, params.min_eigen_threshold);
        else
            cv::calcOpticalFlowPyrLK(previous.levels, next.levels, from, to, status, cv::noArray(), params.window,
                                     params.max_level, criteria, 0, params.min_eigen_threshold);
        return;
    }
    CV_Assert(!previous.empty() && !next.empty());
    CV_Assert(params.window.width >= 3 && params.window.height >= 3);
    const int max_level = std::clamp(params.max_level, 0, std::min(previous.levelCount(), next.levelCount()) - 1);
    const double epsilon2 = params.epsilon * params.epsilon;
    LucasKanadeParams p = params;
    p.max_iterations = std::clamp(params.max_iterations, 0, 100);

    Kernels kernels;
    kernels.vector = kernel == LucasKanadeKernel::Best;
    Window win;
    win.resize(params.window);
    to.resize(from.size());
    status.assign(from.size(), 0);
    if (errors != nullptr)
        errors->assign(from.size(), 0.f);
    for (std::size_t i = 0; i < from.size(); ++i)
        trackPoint(previous, next, from[i], to[i], status[i], errors != nullptr ? &(*errors)[i] : nullptr, max_level,
                   p, epsilon2, kernels, win);
}

} // namespace uavstab
