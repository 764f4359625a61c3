#include "tracking_pyramid.hpp"

#include <cstdint>

#include <opencv2/imgproc.hpp>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define UAVSTAB_HAVE_X86 1
#endif

namespace uavstab {

namespace {

// One row of derivatives from the vertical sums of its three source rows (`smooth`:
// 3 * (above + below) + 10 * centre, `diff`: below - above), each with one mirrored column
// on both sides: dx = smooth[x + 1] - smooth[x - 1], dy = 3 * (diff[x - 1] + diff[x + 1]) +
// 10 * diff[x]. Every value fits in 16 bits (at most 16 * 255).
void horizontalScalar(const std::int16_t *smooth, const std::int16_t *diff, std::int16_t *out, int x, int cols)
{
    for (; x < cols; ++x) {
        out[2 * x] = std::int16_t(smooth[x + 1] - smooth[x - 1]);
        out[2 * x + 1] = std::int16_t((diff[x + 1] + diff[x - 1]) * 3 + diff[x] * 10);
    }
}

void verticalScalar(const std::uint8_t *above, const std::uint8_t *centre, const std::uint8_t *below,
                    std::int16_t *smooth, std::int16_t *diff, int x, int cols)
{
    for (; x < cols; ++x) {
        smooth[x] = std::int16_t((above[x] + below[x]) * 3 + centre[x] * 10);
        diff[x] = std::int16_t(below[x] - above[x]);
    }
}

#ifdef UAVSTAB_HAVE_X86

bool cpuHasAvx2()
{
    static const bool has = __builtin_cpu_supports("avx2");
    return has;
}

__attribute__((target("avx2"))) int verticalAvx2(const std::uint8_t *above, const std::uint8_t *centre,
                                                 const std::uint8_t *below, std::int16_t *smooth, std::int16_t *diff,
                                                 int cols)
{
    const __m256i three = _mm256_set1_epi16(3), ten = _mm256_set1_epi16(10);
    int x = 0;
    for (; x + 16 <= cols; x += 16) {
        const __m256i a = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i *>(above + x)));
        const __m256i c = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i *>(centre + x)));
        const __m256i b = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i *>(below + x)));
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(smooth + x),
                            _mm256_add_epi16(_mm256_mullo_epi16(_mm256_add_epi16(a, b), three),
                                             _mm256_mullo_epi16(c, ten)));
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(diff + x), _mm256_sub_epi16(b, a));
    }
    return x;
}

__attribute__((target("avx2"))) int horizontalAvx2(const std::int16_t *smooth, const std::int16_t *diff,
                                                   std::int16_t *out, int cols)
{
    const __m256i three = _mm256_set1_epi16(3), ten = _mm256_set1_epi16(10);
    int x = 0;
    for (; x + 16 <= cols; x += 16) {
        const __m256i sl = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(smooth + x - 1));
        const __m256i sr = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(smooth + x + 1));
        const __m256i dl = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(diff + x - 1));
        const __m256i dc = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(diff + x));
        const __m256i dr = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(diff + x + 1));
        const __m256i dx = _mm256_sub_epi16(sr, sl);
        const __m256i dy = _mm256_add_epi16(_mm256_mullo_epi16(_mm256_add_epi16(dl, dr), three),
                                            _mm256_mullo_epi16(dc, ten));
        // Interleave (dx, dy): unpack works within 128-bit halves, so the halves are swapped back.
        const __m256i lo = _mm256_unpacklo_epi16(dx, dy), hi = _mm256_unpackhi_epi16(dx, dy);
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out + 2 * x), _mm256_permute2x128_si256(lo, hi, 0x20));
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out + 2 * x + 16), _mm256_permute2x128_si256(lo, hi, 0x31));
    }
    return x;
}

#endif // UAVSTAB_HAVE_X86

} // namespace

void scharrDerivatives(const cv::Mat &src, cv::Mat &dst, bool vector)
{
    CV_Assert(src.type() == CV_8UC1 && dst.type() == CV_16SC2 && dst.size() == src.size());
    const int rows = src.rows, cols = src.cols;
    // Row sums with one mirrored column each side (and room for a vector's overrun).
    std::vector<std::int16_t> buffer(2 * (std::size_t(cols) + 34));
    std::int16_t *smooth = buffer.data() + 1, *diff = smooth + cols + 34;
    bool use_vector = false;
#ifdef UAVSTAB_HAVE_X86
    use_vector = vector && cpuHasAvx2();
#else
    (void)vector;
#endif
    for (int y = 0; y < rows; ++y) {
        const std::uint8_t *above = src.ptr<std::uint8_t>(y > 0 ? y - 1 : rows > 1 ? 1 : 0);
        const std::uint8_t *centre = src.ptr<std::uint8_t>(y);
        const std::uint8_t *below = src.ptr<std::uint8_t>(y < rows - 1 ? y + 1 : rows > 1 ? rows - 2 : 0);
        std::int16_t *out = dst.ptr<std::int16_t>(y);
        int x = 0;
#ifdef UAVSTAB_HAVE_X86
        if (use_vector)
            x = verticalAvx2(above, centre, below, smooth, diff, cols);
#endif
        verticalScalar(above, centre, below, smooth, diff, x, cols);
        const int first = cols > 1 ? 1 : 0, last = cols > 1 ? cols - 2 : 0;
        smooth[-1] = smooth[first];
        smooth[cols] = smooth[last];
        diff[-1] = diff[first];
        diff[cols] = diff[last];
        x = 0;
#ifdef UAVSTAB_HAVE_X86
        if (use_vector)
            x = horizontalAvx2(smooth, diff, out, cols);
#endif
        horizontalScalar(smooth, diff, out, x, cols);
    }
}

int buildTrackingPyramid(const cv::Mat &image, std::vector<cv::Mat> &pyramid, cv::Size window, int max_level)
{
    CV_Assert(image.type() == CV_8UC1 && window.width > 2 && window.height > 2 && max_level >= 0);
    pyramid.resize(std::size_t(2 * (max_level + 1)));
    const int bw = window.width, bh = window.height;
    // A padded buffer for a level of `size`, reused when it already is one; the level is its
    // interior. Fresh derivative buffers are zeroed: their border stays zero (only the
    // interior is ever written).
    auto level = [&](cv::Mat &m, cv::Size size, int type) {
        if (!m.empty())
            m.adjustROI(bh, bh, bw, bw);
        if (m.type() != type || m.cols != size.width + 2 * bw || m.rows != size.height + 2 * bh) {
            m.create(size.height + 2 * bh, size.width + 2 * bw, type);
            if (type != CV_8UC1)
                m.setTo(cv::Scalar::all(0));
        }
        m.adjustROI(-bh, -bh, -bw, -bw);
    };
    cv::Size size = image.size();
    for (int l = 0; l <= max_level; ++l) {
        cv::Mat &img = pyramid[std::size_t(2 * l)];
        level(img, size, CV_8UC1);
        cv::Mat padded;
        if (l == 0) {
            img.adjustROI(bh, bh, bw, bw);
            cv::copyMakeBorder(image, img, bh, bh, bw, bw, cv::BORDER_REFLECT_101);
            img.adjustROI(-bh, -bh, -bw, -bw);
        } else {
            cv::pyrDown(pyramid[std::size_t(2 * (l - 1))], img, size);
            img.adjustROI(bh, bh, bw, bw);
            padded = img;
            img.adjustROI(-bh, -bh, -bw, -bw);
            cv::copyMakeBorder(img, padded, bh, bh, bw, bw, cv::BORDER_REFLECT_101 | cv::BORDER_ISOLATED);
        }
        cv::Mat &deriv = pyramid[std::size_t(2 * l + 1)];
        level(deriv, size, CV_16SC2);
        scharrDerivatives(img, deriv);
        size = cv::Size((size.width + 1) / 2, (size.height + 1) / 2);
        if (size.width <= window.width || size.height <= window.height) {
            pyramid.resize(std::size_t(2 * (l + 1)));
            return l;
        }
    }
    return max_level;
}

} // namespace uavstab
