#include "estimate/scharr_derivatives.hpp"

#include <algorithm>
#include <cstring>

#include "cpu_features.hpp"

#ifdef UAVSTAB_HAVE_X86
#include <immintrin.h>
#endif

namespace uavstab {

namespace {

// Columns [x, end) of image row `centre` (with the rows above and below): dx = smooth(x + 1) -
// smooth(x - 1), dy = 3 * (diff(x - 1) + diff(x + 1)) + 10 * diff(x), where smooth = 3 *
// (above + below) + 10 * centre and diff = below - above. Every value fits in 16 bits.
void rowScalar(const std::uint8_t *above, const std::uint8_t *centre, const std::uint8_t *below, int x, int end,
               std::int16_t *out)
{
    auto smooth = [&](int i) { return (above[i] + below[i]) * 3 + centre[i] * 10; };
    auto diff = [&](int i) { return below[i] - above[i]; };
    for (; x < end; ++x, out += 2) {
        out[0] = std::int16_t(smooth(x + 1) - smooth(x - 1));
        out[1] = std::int16_t((diff(x - 1) + diff(x + 1)) * 3 + diff(x) * 10);
    }
}

#ifdef UAVSTAB_HAVE_X86

__attribute__((target("avx2"))) inline __m256i widen(const std::uint8_t *p)
{
    return _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i *>(p)));
}

// rowScalar 16 columns at a time; returns where it stopped.
__attribute__((target("avx2"))) int rowAvx2(const std::uint8_t *above, const std::uint8_t *centre,
                                            const std::uint8_t *below, int x, int end, std::int16_t *out)
{
    const __m256i three = _mm256_set1_epi16(3), ten = _mm256_set1_epi16(10);
    for (; x + 16 <= end; x += 16, out += 32) {
        const __m256i smooth_left = _mm256_add_epi16(
            _mm256_mullo_epi16(_mm256_add_epi16(widen(above + x - 1), widen(below + x - 1)), three),
            _mm256_mullo_epi16(widen(centre + x - 1), ten));
        const __m256i smooth_right = _mm256_add_epi16(
            _mm256_mullo_epi16(_mm256_add_epi16(widen(above + x + 1), widen(below + x + 1)), three),
            _mm256_mullo_epi16(widen(centre + x + 1), ten));
        const __m256i diff_left = _mm256_sub_epi16(widen(below + x - 1), widen(above + x - 1));
        const __m256i diff_centre = _mm256_sub_epi16(widen(below + x), widen(above + x));
        const __m256i diff_right = _mm256_sub_epi16(widen(below + x + 1), widen(above + x + 1));
        const __m256i dx = _mm256_sub_epi16(smooth_right, smooth_left);
        const __m256i dy = _mm256_add_epi16(_mm256_mullo_epi16(_mm256_add_epi16(diff_left, diff_right), three),
                                            _mm256_mullo_epi16(diff_centre, ten));
        // Interleave (dx, dy): unpack works within 128-bit halves, so the halves are put back in order.
        const __m256i lo = _mm256_unpacklo_epi16(dx, dy), hi = _mm256_unpackhi_epi16(dx, dy);
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out), _mm256_permute2x128_si256(lo, hi, 0x20));
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out + 16), _mm256_permute2x128_si256(lo, hi, 0x31));
    }
    return x;
}

#endif // UAVSTAB_HAVE_X86

} // namespace

void scharrRegion(const cv::Mat &level, cv::Point origin, cv::Size size, std::int16_t *out, std::size_t out_step,
                  bool vector)
{
    CV_Assert(level.type() == CV_8UC1);
#ifdef UAVSTAB_HAVE_X86
    const bool use_vector = vector && cpuHasAvx2();
#else
    (void)vector;
#endif
    // The image's columns within the region; the rest are zero.
    const int x_begin = std::clamp(origin.x, 0, level.cols), x_end = std::clamp(origin.x + size.width, 0, level.cols);
    const std::size_t row_bytes = std::size_t(size.width) * 2 * sizeof(std::int16_t);
    for (int r = 0; r < size.height; ++r) {
        std::int16_t *row = out + std::size_t(r) * out_step;
        const int y = origin.y + r;
        if (y < 0 || y >= level.rows || x_begin >= x_end) {
            std::memset(row, 0, row_bytes);
            continue;
        }
        std::memset(row, 0, std::size_t(x_begin - origin.x) * 2 * sizeof(std::int16_t));
        std::memset(row + 2 * (x_end - origin.x), 0, std::size_t(origin.x + size.width - x_end) * 2 * sizeof(std::int16_t));
        // The padding mirrors the image (row -1 is row 1, column -1 column 1), as calcSharrDeriv
        // does at the edges (a one-pixel image: its single row and column).
        const std::uint8_t *above = level.ptr<std::uint8_t>(y) - level.step[0];
        const std::uint8_t *centre = level.ptr<std::uint8_t>(y);
        const std::uint8_t *below = level.ptr<std::uint8_t>(y) + level.step[0];
        std::int16_t *dst = row + 2 * (x_begin - origin.x);
        int x = x_begin;
#ifdef UAVSTAB_HAVE_X86
        if (use_vector)
            x = rowAvx2(above, centre, below, x, x_end, dst);
#endif
        rowScalar(above, centre, below, x, x_end, dst + 2 * (x - x_begin));
    }
}

} // namespace uavstab
