#include "render/bilinear_warp.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core/hal/intrin.hpp>

#include "cpu_features.hpp"
#include "render/warp_mesh.hpp"

#ifdef UAVSTAB_HAVE_X86
#include <immintrin.h>
#endif

// The 128-bit kernel: OpenCV's universal intrinsics (SSE2 on x86, NEON on ARM at compile
// time) plus one byte shuffle (pshufb, needing SSSE3, which x86 checks at run time; tbl on
// NEON). Little-endian only: it pairs two taps as the low and high byte of a 16-bit lane.
#if CV_SIMD128 && (CV_SSE2 || CV_NEON) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define UAVSTAB_HAVE_SIMD128 1
#ifdef UAVSTAB_HAVE_X86
#define UAVSTAB_TARGET_SIMD128 __attribute__((target("ssse3")))
#else
#define UAVSTAB_TARGET_SIMD128
#endif
#endif

namespace uavstab {

namespace {

constexpr int kFracBits = 6;  // 1/64 pixel
constexpr int kOne = 1 << kFracBits;

// One output pixel, any position: taps outside the frame read the border (constant) or
// the nearest edge pixel (replicate). The arithmetic matches the SIMD path.
inline void samplePixel(const PlaneSpan &src, int channels, double sx, double sy, bool replicate,
                        const std::uint8_t *border, std::uint8_t *out)
{
    if (std::isnan(sx) || std::isnan(sy)) {
        for (int c = 0; c < channels; ++c)
            out[c] = border[c];
        return;
    }
    // Far outside is as good as just outside (keeps the integer maths in range).
    const double qx = std::clamp(std::floor(sx * kOne), -2.0 * kOne, (src.width + 1.0) * kOne);
    const double qy = std::clamp(std::floor(sy * kOne), -2.0 * kOne, (src.height + 1.0) * kOne);
    const long lx = long(qx), ly = long(qy);
    const long ix = lx >> kFracBits, iy = ly >> kFracBits;
    const int fx = int(lx & (kOne - 1)), fy = int(ly & (kOne - 1));
    for (int c = 0; c < channels; ++c) {
        int p[2][2];
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                long x = ix + dx, y = iy + dy;
                const bool inside = x >= 0 && y >= 0 && x < src.width && y < src.height;
                if (!inside && !replicate) {
                    p[dy][dx] = border[c];
                    continue;
                }
                x = std::clamp(x, 0L, long(src.width) - 1);
                y = std::clamp(y, 0L, long(src.height) - 1);
                p[dy][dx] = src.data[y * src.stride + x * channels + c];
            }
        const int t = p[0][0] * (kOne - fx) + p[0][1] * fx;
        const int b = p[1][0] * (kOne - fx) + p[1][1] * fx;
        const int v = t + (((b - t) * (fy << 9) + (1 << 14)) >> 15);
        out[c] = std::uint8_t(std::clamp((v + kOne / 2) >> kFracBits, 0, 255));
    }
}

// A chunk is 16 output pixels: 16 / C pixels per 256-bit vector of 16-bit lanes, so
// C vectors. For lane l of vector v (pixel j = v * 16 / C + l / C, channel l % C): the
// source offset of pixel j from the chunk's first pixel, in 1/1024 px. Every kernel
// (AVX2, 128-bit, scalar) takes these same offsets, so all compute the same positions.
constexpr int kChunk = 16;

struct LaneSteps {
    alignas(32) std::int16_t offset_x[4][16];
    alignas(32) std::int16_t offset_y[4][16];
    alignas(32) std::int16_t channel[16];
    alignas(32) std::int16_t is_high_half[16];
    int vectors;       // C
    int half_pixels;   // pixels per 128-bit half: 8 / C
};

// The lanes' source offsets for a matrix: j * m * 1024 rounded as std::lround (halves away
// from zero) for pixel j of the chunk. Spelt out rather than calling lround (a library call)
// so that the loop vectorises: a matrix per row recomputes these on most rows. v - int(v) is
// exact.
inline void setOffsets(LaneSteps &steps, const double m[6])
{
    std::int16_t pixel_x[kChunk], pixel_y[kChunk];
    for (int j = 0; j < kChunk; ++j) {
        const double vx = j * m[0] * 1024.0, vy = j * m[3] * 1024.0;
        const int ix = int(vx), iy = int(vy);
        const double fx = vx - double(ix), fy = vy - double(iy);
        pixel_x[j] = std::int16_t(ix + (fx >= 0.5) - (fx <= -0.5));
        pixel_y[j] = std::int16_t(iy + (fy >= 0.5) - (fy <= -0.5));
    }
    const int channels = steps.vectors;
    for (int v = 0; v < channels; ++v)
        for (int l = 0; l < 16; ++l) {
            const int j = v * (16 / channels) + l / channels;
            steps.offset_x[v][l] = pixel_x[j];
            steps.offset_y[v][l] = pixel_y[j];
        }
}

LaneSteps laneSteps(const double m[6], int channels)
{
    LaneSteps steps{};
    steps.vectors = channels;
    steps.half_pixels = 8 / channels;
    for (int l = 0; l < 16; ++l) {
        steps.channel[l] = std::int16_t(l % channels);
        steps.is_high_half[l] = std::int16_t(l >= 8);
    }
    setOffsets(steps, m);
    return steps;
}

// Where the 8-bit kernels get each row's matrix and lane steps. One matrix for every row
// (the single-transform warp: its steps computed once)...
class OneMatrix {
public:
    OneMatrix(const double m[6], int channels) : m_(m), steps_(laneSteps(m, channels)) {}
    const double *row(int) const { return m_; }
    const LaneSteps &steps() const { return steps_; }

private:
    const double *m_;
    LaneSteps steps_;
};

// ...or a matrix per row (rolling-shutter correction). The steps depend on m[0] and m[3]
// only, which change slowly down a frame if at all: recomputed only when they change from
// the previous row, so that a row costs little more than with one matrix.
class MatrixPerRow {
public:
    // The first row's steps are ready, for the lane layout kernels read before their loop.
    MatrixPerRow(const std::array<double, 6> *row_m, int row_begin, int channels)
        : row_m_(row_m), row_begin_(row_begin), steps_(laneSteps(row_m[0].data(), channels)),
          steps_m0_(row_m[0][0]), steps_m3_(row_m[0][3])
    {
    }
    const double *row(int y)
    {
        const double *m = row_m_[y - row_begin_].data();
        if (!(m[0] == steps_m0_ && m[3] == steps_m3_)) {
            setOffsets(steps_, m);
            steps_m0_ = m[0];
            steps_m3_ = m[3];
        }
        return m;
    }
    const LaneSteps &steps() const { return steps_; }

private:
    const std::array<double, 6> *row_m_;
    int row_begin_;
    LaneSteps steps_;
    double steps_m0_, steps_m3_;  // the matrix entries steps_ was computed for
};

// ...or a matrix per chunk (the mesh warp): along one output row, inside one mesh cell, the
// mesh's bilinear interpolation is linear in x, so each chunk is warped by the matrix
// m0 = (B.x - A.x) / cell, m3 = (B.y - A.y) / cell, m1 = m4 = 0, m2 = A.x - m0 * x_A,
// m5 = A.y - m3 * x_A, with A, B the cell's nodes interpolated down to the row and x_A the
// cell's first column. Kernels call beginRow, then chunk() for each chunk in order.
//
// The lane offsets change with nearly every chunk here, so they come from integers rather
// than setOffsets' 32 double products, in arithmetic a vector kernel does in a few 16-bit
// multiplies: m0 rounded to 2^-25 px (stepOfM0: s = m0 2^25, half away from zero) and pixel
// j's offset (j s + 2^14) >> 15 (offsetX: j m0 1024 rounded half up; the kernel splits s
// into b 2^15 + a, a in [-2^14, 2^14), and takes j b + pmulhrsw(a, j)); m3 rounded to
// 2^-19 px (stepOfM3: |m3| <= 0.06, so |s| < 2^15) and the offset sign(s) ((|s| j 2^6 + 2^14)
// >> 15) (offsetY: pmulhrsw of |s| and j 2^6, the sign applied). That is setOffsets' rounding
// of j * m * 1024 exactly whenever m0 is a multiple of 2^-25 and m3 of 2^-19; else an
// offset may differ from it by 1/1024 px where j * m * 1024 lies within 15 2^-16 (x) or
// 15 2^-10 (y) of a half.
constexpr int kStepXBits = 25, kStepYBits = 19;

inline int roundStep(double v)
{
    const int i = int(v);  // |v| <= 1.25 2^25: in range
    const double f = v - double(i);
    return i + (f >= 0.5) - (f <= -0.5);
}
inline int stepOfM0(double m0) { return roundStep(m0 * double(1 << kStepXBits)); }
inline int stepOfM3(double m3) { return roundStep(m3 * double(1 << kStepYBits)); }

// A taken chunk's steps: step_x >= 0 and <= 1.25 2^25, |step_y| < 2^15.
inline int offsetX(int step, int j)
{
    return (j * step + (1 << 14)) >> 15;
}

inline int offsetY(int step, int j)
{
    const int r = (std::abs(step) * (j << 6) + (1 << 14)) >> 15;
    return step < 0 ? -r : r;
}

// The pixel of the chunk that lane l of vector v holds (C channels).
constexpr int lanePixel(int channels, int v, int l)
{
    return v * (16 / channels) + l / channels;
}

// Whether the window trick takes a chunk of this matrix (warpPlaneBilinearHandles' bounds,
// which also keep the offsets and steps in 16 bits).
inline bool chunkStepsOk(double m0, double m3)
{
    return m0 > 0.0 && m0 <= 1.25 && std::abs(m3) * (kChunk - 1) <= 0.9;
}

class MatrixPerChunk {
public:
    MatrixPerChunk(const WarpMesh &mesh, int channels, bool window_fits, int chunks_in_row)
        // The row's nodes with room for the AVX2 planner's groups of 4 chunks (5 nodes).
        : mesh_(mesh), row_x_(std::size_t(std::max(mesh.columns, chunks_in_row + 5)), 0.0),
          row_y_(row_x_.size(), 0.0), steps_(laneSteps(kIdentity, channels)), channels_(channels),
          window_fits_(window_fits)
    {
        // Room for 3 entries past the last chunk: the AVX2 planner reads groups of 4.
        const std::size_t n = std::size_t(chunks_in_row) + 4;
        for (std::vector<double> *v : {&m0_, &m2_, &m3_, &m5_})
            v->assign(n, 0.0);
        for (std::vector<int> *v : {&step_x_, &step_y_, &last_window_, &last_offset_y_, &vector_ok_})
            v->assign(n, 0);
    }
    const WarpMesh &mesh() const { return mesh_; }
    int channels() const { return channels_; }
    bool windowFits() const { return window_fits_; }

    // Every chunk's matrix of output row y (chunk c at columns [16 c, 16 c + 16)), and for
    // those the window trick takes (chunkStepsOk) its steps.
    void beginRow(int y, int chunks_in_row)
    {
        mesh_.rowAt(y, row_x_.data(), row_y_.data());
        const int per_cell = mesh_.cell / kChunk;
        for (int c = 0, cell = 0, in_cell = 0; c < chunks_in_row; ++c) {
            setChunk(c, cell);
            if (++in_cell == per_cell) {
                in_cell = 0;
                ++cell;
            }
        }
    }
    // Chunk c's matrix from cell `cell`'s nodes in the row (m1 = m4 = 0).
    void chunkMatrix(int cell, double m[6]) const
    {
        const int cell_size = mesh_.cell;
        const double x_a = double(cell) * cell_size;
        const double ax = row_x_[std::size_t(cell)], bx = row_x_[std::size_t(cell) + 1];
        const double ay = row_y_[std::size_t(cell)], by = row_y_[std::size_t(cell) + 1];
        // A 16-px cell's division as a multiplication (the same doubles).
        const double inv_cell = cell_size == kChunk ? 1.0 / kChunk : 0.0;
        const double m0 = inv_cell != 0.0 ? (bx - ax) * inv_cell : (bx - ax) / cell_size;
        const double m3 = inv_cell != 0.0 ? (by - ay) * inv_cell : (by - ay) / cell_size;
        m[0] = m0;
        m[1] = 0.0;
        m[2] = ax - m0 * x_a;
        m[3] = m3;
        m[4] = 0.0;
        m[5] = ay - m3 * x_a;
    }
    // Chunk c's entries from cell `cell`'s nodes (what beginRow computes).
    void setChunk(int c, int cell)
    {
        double m[6];
        chunkMatrix(cell, m);
        m0_[std::size_t(c)] = m[0];
        m2_[std::size_t(c)] = m[2];
        m3_[std::size_t(c)] = m[3];
        m5_[std::size_t(c)] = m[5];
        const bool ok = window_fits_ && chunkStepsOk(m[0], m[3]);
        vector_ok_[std::size_t(c)] = ok;
        const int step_x = ok ? stepOfM0(m[0]) : 0, step_y = ok ? stepOfM3(m[3]) : 0;
        step_x_[std::size_t(c)] = step_x;
        step_y_[std::size_t(c)] = step_y;
        last_window_[std::size_t(c)] = offsetX(step_x, lanePixel(channels_, channels_ - 1, 8));
        last_offset_y_[std::size_t(c)] = offsetY(step_y, lanePixel(channels_, channels_ - 1, 15));
    }
    // Chunk c's matrix.
    void matrix(int c, double m[6]) const
    {
        m[0] = m0_[std::size_t(c)];
        m[1] = 0.0;
        m[2] = m2_[std::size_t(c)];
        m[3] = m3_[std::size_t(c)];
        m[4] = 0.0;
        m[5] = m5_[std::size_t(c)];
    }
    // Whether a vector kernel may take chunk c (else: per pixel with its matrix).
    bool vectorOk(int c) const { return vector_ok_[std::size_t(c)] != 0; }
    // Chunk c's steps (stepOfM0, stepOfM3) and what planChunk reads of its lanes: the last
    // window's offset and the last pixel's vertical offset.
    int stepX(int c) const { return step_x_[std::size_t(c)]; }
    int stepY(int c) const { return step_y_[std::size_t(c)]; }
    int lastWindow(int c) const { return last_window_[std::size_t(c)]; }
    int lastOffsetY(int c) const { return last_offset_y_[std::size_t(c)]; }
    // Chunk c's lanes, for kernels that read them from memory: recomputed only when its
    // steps differ from the last chunk asked for.
    const LaneSteps &steps(int c)
    {
        const int step_x = stepX(c), step_y = stepY(c);
        if (!(lanes_valid_ && step_x == lanes_x_ && step_y == lanes_y_)) {
            for (int v = 0; v < channels_; ++v)
                for (int l = 0; l < 16; ++l) {
                    steps_.offset_x[v][l] = std::int16_t(offsetX(step_x, lanePixel(channels_, v, l)));
                    steps_.offset_y[v][l] = std::int16_t(offsetY(step_y, lanePixel(channels_, v, l)));
                }
            lanes_x_ = step_x;
            lanes_y_ = step_y;
            lanes_valid_ = true;
        }
        return steps_;
    }
    // The lane layout (channel, half), the same for every chunk.
    const LaneSteps &layout() const { return steps_; }
#ifdef UAVSTAB_HAVE_X86
    // Only the row's node positions (rowAt's doubles), for the AVX2 planner of one-chunk
    // cells, which derives each chunk's entries itself.
    void beginRowNodesAvx2(int y);
#endif
    // The row's node positions and arrays, for the AVX2 planners.
    const double *rowX() const { return row_x_.data(); }
    const double *rowY() const { return row_y_.data(); }
    const double *m0() const { return m0_.data(); }
    const double *m2() const { return m2_.data(); }
    const double *m3() const { return m3_.data(); }
    const double *m5() const { return m5_.data(); }
    const int *stepsX() const { return step_x_.data(); }
    const int *stepsY() const { return step_y_.data(); }
    const int *lastWindows() const { return last_window_.data(); }
    const int *lastOffsetsY() const { return last_offset_y_.data(); }
    const int *vectorOks() const { return vector_ok_.data(); }

private:
    static constexpr double kIdentity[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
    const WarpMesh &mesh_;
    std::vector<double> row_x_, row_y_;  // the row's node positions
    LaneSteps steps_;
    int channels_;
    bool window_fits_;
    // Per chunk of the row.
    std::vector<double> m0_, m2_, m3_, m5_;
    std::vector<int> step_x_, step_y_, last_window_, last_offset_y_, vector_ok_;
    bool lanes_valid_ = false;
    int lanes_x_ = 0, lanes_y_ = 0;  // the steps steps_ holds
};

inline void samplePixels(const PlaneSpan &src, int channels, const double m[6], bool replicate,
                         const std::uint8_t *border, std::uint8_t *out, int x, int y, int count)
{
    for (int j = 0; j < count; ++j)
        samplePixel(src, channels, m[0] * (x + j) + m[1] * y + m[2], m[3] * (x + j) + m[4] * y + m[5], replicate,
                    border, out + (x + j) * channels);
}

// Output pixels [x, dst_width) of row y at the mesh's own positions.
inline void samplePixelsAtMesh(const PlaneSpan &src, int channels, const WarpMesh &mesh, bool replicate,
                               const std::uint8_t *border, std::uint8_t *out, int x, int y, int dst_width)
{
    for (; x < dst_width; ++x) {
        const Point2 s = mesh.at(x, y);
        samplePixel(src, channels, s.x, s.y, replicate, border, out + x * channels);
    }
}

// The plan of up to kPlanChunks chunks of a row, for the vector kernels (planChunksAvx2,
// planChunksPortable): per chunk what planChunk returns.
constexpr int kPlanChunks = 64;

// Room for 3 entries past the last chunk: a planner writes groups of 4.
struct RowPlan {
    alignas(32) int ix0[kPlanChunks + 4];
    alignas(32) int iy0[kPlanChunks + 4];
    alignas(32) int frx[kPlanChunks + 4];
    alignas(32) int fry[kPlanChunks + 4];
    alignas(32) int ky_last[kPlanChunks + 4];
    alignas(32) int vector_ok[kPlanChunks + 4];  // -1: a vector kernel takes the chunk
};

// The mesh warp's plan: besides planChunk's, what the AVX2 kernel would otherwise derive
// per chunk in general registers. Each 16-bit value twice in an int (both halves), so that
// the kernel broadcasts it with one load: frx, fry; stepOfM0 split into b 2^15 + a; |stepY|
// and its sign (+-1); and the byte each window of vector v, half h starts at in its source
// rows ((ix0 + k) * C, k = the window's first tap), [v * 2 + h].
struct MeshPlan : RowPlan {
    alignas(32) int frx2[kPlanChunks + 4];
    alignas(32) int fry2[kPlanChunks + 4];
    alignas(32) int step_x_b2[kPlanChunks + 4];
    alignas(32) int step_x_a2[kPlanChunks + 4];
    alignas(32) int step_y_abs2[kPlanChunks + 4];
    alignas(32) int step_y_sign2[kPlanChunks + 4];
    alignas(32) int window_byte[4][kPlanChunks + 4];
};

// The chunks [lo, hi) of row y that pass every one of planChunk's tests (all taps inside,
// the windows inside the row, at most one row step) by a margin of 1/16 px, far beyond
// the rounding of its double arithmetic: there the planner need only compute positions.
// Along a row the source moves linearly (m[0] > 0), so each test bounds an interval.
struct ChunkRange {
    int lo = 0, hi = 0;
};

inline ChunkRange interiorChunks(const PlaneSpan &src, int channels, const double m[6], const LaneSteps &steps,
                                 int y, int chunks_in_row)
{
    constexpr double kMargin = 1.0 / 16;
    const double bx = m[1] * y + m[2], by = m[4] * y + m[5];
    if (!(std::isfinite(bx) && std::isfinite(by) && m[0] > 0.0 && std::isfinite(m[3])))
        return {};
    const int last_window = steps.offset_x[steps.vectors - 1][steps.half_pixels * channels];
    // sx0 = bx + 16 m0 c (the chunk's first pixel), the last pixel 15 m0 further; the last
    // window's 16 bytes start at most last_window / 1024 px past sx0.
    const double step_x = kChunk * m[0];
    const double reach_x = std::max(m[0] * (kChunk - 1) + 1.0, last_window / 1024.0 + 16.0 / channels);
    double c_lo = (kMargin - bx) / step_x;
    double c_hi = (src.width - 1 - kMargin - reach_x - bx) / step_x;
    // sy0 = by + 16 m3 c, the last pixel 15 m3 further; both rows of every tap inside.
    const double below = std::min(0.0, m[3] * (kChunk - 1)), above = std::max(0.0, m[3] * (kChunk - 1));
    const double y_lo = kMargin - below, y_hi = src.height - 1 - kMargin - above;  // sy0's bounds
    const double step_y = kChunk * m[3];
    if (step_y == 0.0) {
        if (!(by >= y_lo && by <= y_hi))
            return {};
    } else if (step_y > 0.0) {
        c_lo = std::max(c_lo, (y_lo - by) / step_y);
        c_hi = std::min(c_hi, (y_hi - by) / step_y);
    } else {
        c_lo = std::max(c_lo, (y_hi - by) / step_y);
        c_hi = std::min(c_hi, (y_lo - by) / step_y);
    }
    c_lo = std::clamp(std::ceil(c_lo), 0.0, double(chunks_in_row));
    c_hi = std::clamp(std::floor(c_hi) + 1.0, 0.0, double(chunks_in_row));
    if (!(c_hi > c_lo))
        return {};
    return {int(c_lo), int(c_hi)};
}

#ifdef UAVSTAB_HAVE_X86

// Asks for the source lines an output row two rows further down will read: one per 64
// bytes of this row's planned chunks, kPrefetchRows below where each chunk reads now. A
// rotated frame reads its source along a slant, a few dozen bytes of each row at a time,
// which the hardware prefetchers do not follow: a 1080p luma plane fresh from memory warped
// with a rotation of 0.3-0.8 degrees took 1.2-1.5 times as long without this (AVX2, one
// thread; no change without rotation). The 128-bit kernel, slower per pixel, showed no gain
// on x86 and goes without. Positions only, so no kernel's bytes change.
constexpr int kPrefetchRows = 3;

inline void prefetchBelow(const PlaneSpan &src, int channels, const RowPlan &plan, int chunks)
{
    const int step = std::max(1, 64 / (kChunk * channels));
    for (int c = 0; c < chunks; c += step)
        if (plan.vector_ok[c]) {
            const int row = std::min(plan.iy0[c] + kPrefetchRows, src.height - 1);
            __builtin_prefetch(src.data + std::size_t(row) * std::size_t(src.stride) +
                               std::size_t(plan.ix0[c]) * std::size_t(channels));
        }
}

// Called where AVX2 code hands over to code built without it (the per-pixel paths, the
// caller): SSE instructions that run while the 256-bit registers' upper halves are dirty
// pay for it, and GCC leaves them dirty around some calls. The bench's 1080p fisheye
// meshes, built just after a warp, took 0.34 ms instead of 0.24 (Zen 5, one thread).
__attribute__((target("avx"), always_inline)) inline void cleanUpperHalves()
{
    _mm256_zeroupper();
}

__attribute__((target("avx2"))) inline __m256i load2(const std::uint8_t *lo, const std::uint8_t *hi)
{
    return _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i *>(lo))),
                                   _mm_loadu_si128(reinterpret_cast<const __m128i *>(hi)), 1);
}

// Horizontal taps of two source rows, then the vertical blend (16-bit lanes, x64).
__attribute__((target("avx2"))) inline __m256i interpolateRows(const std::uint8_t *top, const std::uint8_t *bottom,
                                                               int byte0, int byte1, __m256i ctrl, __m256i wx,
                                                               __m256i fy_scaled)
{
    const __m256i t = _mm256_maddubs_epi16(_mm256_shuffle_epi8(load2(top + byte0, top + byte1), ctrl), wx);
    const __m256i b = _mm256_maddubs_epi16(_mm256_shuffle_epi8(load2(bottom + byte0, bottom + byte1), ctrl), wx);
    return _mm256_add_epi16(t, _mm256_mulhrs_epi16(_mm256_sub_epi16(b, t), fy_scaled));
}

// Where a run of chunks of one row reads (up to kPlanChunks at a time), decided four chunks
// at once in double vectors: the same operations, so the same roundings and decisions,
// as planChunk (no fused multiply-adds: the target has none).
// Inside interiorChunks' range (Interior) only the positions are computed: every test
// would pass there.
template <bool Interior>
__attribute__((target("avx2"))) inline void planChunksAvx2(const PlaneSpan &src, int channels, const double m[6],
                                                           const LaneSteps &steps, int x_begin, int chunks, int y,
                                                           RowPlan &plan, int at)
{
    const __m256d m0 = _mm256_set1_pd(m[0]), m3 = _mm256_set1_pd(m[3]);
    const __m256d row_x = _mm256_set1_pd(m[1] * y), row_y = _mm256_set1_pd(m[4] * y);
    const __m256d m2 = _mm256_set1_pd(m[2]), m5 = _mm256_set1_pd(m[5]);
    const __m256d last_x = _mm256_set1_pd(m[0] * (kChunk - 1)), last_y = _mm256_set1_pd(m[3] * (kChunk - 1));
    const __m256d zero = _mm256_setzero_pd();
    const __m256d width1 = _mm256_set1_pd(double(src.width - 1)), height1 = _mm256_set1_pd(double(src.height - 1));
    const __m256d k1024 = _mm256_set1_pd(1024.0);
    const __m128i fraction = _mm_set1_epi32(1023);
    const __m128i last_window = _mm_set1_epi32(steps.offset_x[steps.vectors - 1][steps.half_pixels * channels]);
    const __m128i last_offset_y = _mm_set1_epi32(steps.offset_y[steps.vectors - 1][15]);
    const __m128i row_bytes = _mm_set1_epi32(src.width * channels - 16);
    const __m128i height = _mm_set1_epi32(src.height), one = _mm_set1_epi32(1), zero_i = _mm_setzero_si128();
    for (int c = 0; c < chunks; c += 4) {
        const int x = x_begin + c * kChunk;
        const __m256d xs = _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(x), _mm_setr_epi32(0, 16, 32, 48)));
        const __m256d sx0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m0, xs), row_x), m2);
        const __m256d sy0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m3, xs), row_y), m5);
        // Inside, sx0, sy0 >= 0: truncation is the floor, and the position in 1/1024 px
        // (s * 1024 is exact) splits into planChunk's integer part and fraction. Lanes
        // outside hold anything.
        const __m128i qx = _mm256_cvttpd_epi32(_mm256_mul_pd(sx0, k1024));
        const __m128i qy = _mm256_cvttpd_epi32(_mm256_mul_pd(sy0, k1024));
        const __m128i ix0 = _mm_srai_epi32(qx, 10), iy0 = _mm_srai_epi32(qy, 10);
        const __m128i frx = _mm_and_si128(qx, fraction), fry = _mm_and_si128(qy, fraction);
        const __m128i ky_last = _mm_srai_epi32(_mm_add_epi32(fry, last_offset_y), 10);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.ix0 + at + c), ix0);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.iy0 + at + c), iy0);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.frx + at + c), frx);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.fry + at + c), fry);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.ky_last + at + c), ky_last);
        if (Interior) {
            _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.vector_ok + at + c), _mm_set1_epi32(-1));
            continue;
        }
        const __m256d sx1 = _mm256_add_pd(sx0, last_x), sy1 = _mm256_add_pd(sy0, last_y);
        // Every tap inside (false for NaN, as planChunk's comparisons).
        const __m256d inside = _mm256_and_pd(
            _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(sx0, zero, _CMP_GE_OQ), _mm256_cmp_pd(sx1, zero, _CMP_GE_OQ)),
                          _mm256_and_pd(_mm256_cmp_pd(sx0, width1, _CMP_LT_OQ), _mm256_cmp_pd(sx1, width1, _CMP_LT_OQ))),
            _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(sy0, zero, _CMP_GE_OQ), _mm256_cmp_pd(sy1, zero, _CMP_GE_OQ)),
                          _mm256_and_pd(_mm256_cmp_pd(sy0, height1, _CMP_LT_OQ), _mm256_cmp_pd(sy1, height1, _CMP_LT_OQ))));
        const __m128i ky_min = _mm_min_epi32(zero_i, ky_last), ky_max = _mm_max_epi32(zero_i, ky_last);
        // planChunk's refusals: the last window past the row, two row steps, rows outside.
        const __m128i window_end =
            _mm_mullo_epi32(_mm_add_epi32(ix0, _mm_srai_epi32(_mm_add_epi32(frx, last_window), 10)),
                            _mm_set1_epi32(channels));
        const __m128i refused = _mm_or_si128(
            _mm_or_si128(_mm_cmpgt_epi32(window_end, row_bytes), _mm_cmpgt_epi32(_mm_sub_epi32(ky_max, ky_min), one)),
            _mm_or_si128(_mm_cmpgt_epi32(_mm_add_epi32(_mm_add_epi32(iy0, ky_max), one), _mm_sub_epi32(height, one)),
                         _mm_cmpgt_epi32(zero_i, _mm_add_epi32(iy0, ky_min))));
        // The double mask's lanes are 64-bit: take one 32-bit half of each.
        const __m128i inside32 = _mm256_castsi256_si128(
            _mm256_permutevar8x32_epi32(_mm256_castpd_si256(inside), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
        _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.vector_ok + at + c), _mm_andnot_si128(refused, inside32));
    }
}

// The lane layout of the AVX2 kernel, the same for every row's matrix.
struct Avx2Lanes {
    __m256i channel, high_mask, frac_mask, one, next_tap;
};

// The window offsets and lane steps of one row, for vector v of a chunk.
struct Avx2RowSteps {
    int window_lo, window_hi;
    __m256i offset_x, offset_y;
    __m256i window;  // window_lo in the low half's lanes, window_hi in the high half's
};

// One vector of a chunk (16 lanes: its output bytes, not yet packed) from the chunk's plan
// (planChunk's ix0, iy0, frx, fry and the last pixel's row step ky_last): each 128-bit half
// reads one 16-byte window per source row it crosses, and a byte shuffle picks the taps.
template <int C>
__attribute__((target("avx2"), always_inline)) inline __m256i chunkVectorAvx2(const std::uint8_t *src_data, std::size_t stride,
                                                               const Avx2Lanes &lanes, const Avx2RowSteps &steps,
                                                               int ix0, int iy0, int frx, int fry, int ky_last)
{
    const int ky_min = std::min(0, ky_last), ky_max = std::max(0, ky_last);
    const std::uint8_t *row = src_data + std::size_t(iy0 + ky_min) * stride;
    const __m256i frx_v = _mm256_set1_epi16(std::int16_t(frx));
    const __m256i rel_x = _mm256_add_epi16(frx_v, steps.offset_x);
    const __m256i rel_y = _mm256_add_epi16(_mm256_set1_epi16(std::int16_t(fry)), steps.offset_y);
    // Each half reads a window that starts at its first pixel's left tap.
    const int k0 = (frx + steps.window_lo) >> 10;
    const int k1 = (frx + steps.window_hi) >> 10;
    const __m256i kx = _mm256_srli_epi16(rel_x, 10);
    const __m256i fx = _mm256_and_si256(_mm256_srli_epi16(rel_x, 10 - kFracBits), lanes.frac_mask);
    const __m256i fy = _mm256_and_si256(_mm256_srai_epi16(rel_y, 10 - kFracBits), lanes.frac_mask);
    const __m256i window_k = _mm256_srli_epi16(_mm256_add_epi16(frx_v, steps.window), 10);
    // Shuffle control: byte of the left tap in the lane's window, right tap one pixel on.
    __m256i left = _mm256_sub_epi16(kx, window_k);
    if (C == 2) {
        left = _mm256_add_epi16(left, left);
        left = _mm256_add_epi16(left, lanes.channel);
    }
    const __m256i ctrl = _mm256_add_epi16(left, _mm256_add_epi16(_mm256_slli_epi16(left, 8), lanes.next_tap));
    const __m256i wx = _mm256_or_si256(_mm256_sub_epi16(lanes.one, fx), _mm256_slli_epi16(fx, 8));
    const __m256i fy_scaled = _mm256_slli_epi16(fy, 9);
    const int byte0 = (ix0 + k0) * C, byte1 = (ix0 + k1) * C;

    __m256i value = interpolateRows(row, row + stride, byte0, byte1, ctrl, wx, fy_scaled);
    if (ky_max != ky_min) {
        const __m256i lower = interpolateRows(row + stride, row + 2 * stride, byte0, byte1, ctrl, wx, fy_scaled);
        const __m256i ky = _mm256_srai_epi16(rel_y, 10);
        value = _mm256_blendv_epi8(value, lower, _mm256_cmpeq_epi16(ky, _mm256_set1_epi16(std::int16_t(ky_max))));
    }
    return _mm256_srli_epi16(_mm256_add_epi16(value, _mm256_set1_epi16(kOne / 2)), kFracBits);
}

template <int C, class Matrices>
__attribute__((target("avx2"))) void warpRowsAvx2(const PlaneSpan &src, std::uint8_t *dst, int dst_stride,
                                                  int dst_width, int row_begin, int row_end, Matrices &matrices,
                                                  bool replicate, const std::uint8_t border[4])
{
    constexpr int channels = C;
    Avx2Lanes lanes;
    // The lane layout (channel, half) is the same for every matrix.
    lanes.channel = _mm256_load_si256(reinterpret_cast<const __m256i *>(matrices.steps().channel));
    lanes.high_mask = _mm256_sub_epi16(
        _mm256_setzero_si256(), _mm256_load_si256(reinterpret_cast<const __m256i *>(matrices.steps().is_high_half)));
    lanes.frac_mask = _mm256_set1_epi16(kOne - 1);
    lanes.one = _mm256_set1_epi16(kOne);
    lanes.next_tap = _mm256_set1_epi16(std::int16_t(channels << 8));
    const std::size_t stride = std::size_t(src.stride);
    RowPlan plan;

    for (int y = row_begin; y < row_end; ++y) {
        const double *m = matrices.row(y);
        const LaneSteps &steps = matrices.steps();
        constexpr int H = 8 / C;
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        const int chunks_in_row = dst_width / kChunk;
        const ChunkRange interior = interiorChunks(src, channels, m, steps, y, chunks_in_row);
        Avx2RowSteps row_steps[C];
        for (int v = 0; v < C; ++v) {
            row_steps[v].window_lo = steps.offset_x[v][0];
            row_steps[v].window_hi = steps.offset_x[v][H * channels];
            row_steps[v].offset_x = _mm256_load_si256(reinterpret_cast<const __m256i *>(steps.offset_x[v]));
            row_steps[v].offset_y = _mm256_load_si256(reinterpret_cast<const __m256i *>(steps.offset_y[v]));
            row_steps[v].window = _mm256_blendv_epi8(_mm256_set1_epi16(std::int16_t(row_steps[v].window_lo)),
                                                     _mm256_set1_epi16(std::int16_t(row_steps[v].window_hi)),
                                                     lanes.high_mask);
        }
        for (int first = 0; first < chunks_in_row; first += kPlanChunks) {
            const int chunks = std::min(kPlanChunks, chunks_in_row - first);
            // Exact tests only near the frame's edges, in order (each call may write 3 entries
            // past its range, which the next overwrites).
            const int lo = std::clamp(interior.lo - first, 0, chunks), hi = std::clamp(interior.hi - first, lo, chunks);
            if (lo > 0)
                planChunksAvx2<false>(src, channels, m, steps, first * kChunk, lo, y, plan, 0);
            if (hi > lo)
                planChunksAvx2<true>(src, channels, m, steps, (first + lo) * kChunk, hi - lo, y, plan, lo);
            if (chunks > hi)
                planChunksAvx2<false>(src, channels, m, steps, (first + hi) * kChunk, chunks - hi, y, plan, hi);
            prefetchBelow(src, channels, plan, chunks);
            for (int c = 0; c < chunks;) {
                if (C == 1 && c + 2 <= chunks && (plan.vector_ok[c] & plan.vector_ok[c + 1])) {
                    // Two chunks' vectors packed into one 32-byte store.
                    const __m256i a = chunkVectorAvx2<C>(src.data, stride, lanes, row_steps[0], plan.ix0[c],
                                                         plan.iy0[c], plan.frx[c], plan.fry[c], plan.ky_last[c]);
                    const __m256i b =
                        chunkVectorAvx2<C>(src.data, stride, lanes, row_steps[0], plan.ix0[c + 1], plan.iy0[c + 1],
                                           plan.frx[c + 1], plan.fry[c + 1], plan.ky_last[c + 1]);
                    _mm256_storeu_si256(reinterpret_cast<__m256i *>(out + (first + c) * kChunk),
                                        _mm256_permute4x64_epi64(_mm256_packus_epi16(a, b), 0xD8));
                    c += 2;
                    continue;
                }
                const int x = (first + c) * kChunk;
                if (!plan.vector_ok[c]) {
                    samplePixels(src, channels, m, replicate, border, out, x, y, kChunk);
                } else {
                    __m256i vectors[C];
                    for (int v = 0; v < C; ++v)
                        vectors[v] = chunkVectorAvx2<C>(src.data, stride, lanes, row_steps[v], plan.ix0[c],
                                                        plan.iy0[c], plan.frx[c], plan.fry[c], plan.ky_last[c]);
                    // Two channels: the chunk's two vectors in one 32-byte store.
                    const __m256i packed =
                        _mm256_permute4x64_epi64(_mm256_packus_epi16(vectors[0], vectors[C - 1]), 0xD8);
                    if (C == 2)
                        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out + x * channels), packed);
                    else
                        _mm_storeu_si128(reinterpret_cast<__m128i *>(out + x * channels),
                                         _mm256_castsi256_si128(packed));
                }
                ++c;
            }
        }
        const int x = chunks_in_row * kChunk;
        samplePixels(src, channels, m, replicate, border, out, x, y, dst_width - x);
    }
    cleanUpperHalves();
}

#endif // UAVSTAB_HAVE_X86

// Where the chunk of output pixels [x, x + 16) of row y reads, and whether a vector kernel
// may take it: the same decisions, in the same double arithmetic, as warpRowsAvx2's loop
// (the tests check that both kernels write the same bytes).
struct ChunkPlan {
    int ix0, iy0;        // source pixel of the chunk's first output pixel
    int frx, fry;        // its fraction, 1/1024 px
    int ky_min, ky_max;  // source rows crossed in the chunk, relative to iy0
};

// last_window: the lane offset where the chunk's last window starts; last_offset_y: the
// last pixel's vertical offset (both 1/1024 px).
inline bool planChunk(const PlaneSpan &src, int channels, const double m[6], int last_window, int last_offset_y,
                      int x, int y, ChunkPlan &p)
{
    const double last_x = m[0] * (kChunk - 1), last_y = m[3] * (kChunk - 1);
    const int row_bytes = src.width * channels;
    const double sx0 = m[0] * x + m[1] * y + m[2];
    const double sy0 = m[3] * x + m[4] * y + m[5];
    const double sx1 = sx0 + last_x, sy1 = sy0 + last_y;
    if (!(std::min(sx0, sx1) >= 0.0 && std::max(sx0, sx1) < src.width - 1 && std::min(sy0, sy1) >= 0.0 &&
          std::max(sy0, sy1) < src.height - 1))
        return false;
    p.ix0 = int(sx0);
    p.iy0 = int(std::floor(sy0));
    p.frx = int((sx0 - p.ix0) * 1024.0);
    p.fry = int((sy0 - p.iy0) * 1024.0);
    const int ky_last = (p.fry + last_offset_y) >> 10;
    p.ky_min = std::min(0, ky_last);
    p.ky_max = std::max(0, ky_last);
    return !((p.ix0 + ((p.frx + last_window) >> 10)) * channels + 16 > row_bytes || p.ky_max - p.ky_min > 1 ||
             p.iy0 + p.ky_max + 1 >= src.height || p.iy0 + p.ky_min < 0);
}

inline bool planChunk(const PlaneSpan &src, int channels, const double m[6], const LaneSteps &steps, int x, int y,
                      ChunkPlan &p)
{
    return planChunk(src, channels, m, steps.offset_x[steps.vectors - 1][steps.half_pixels * channels],
                     steps.offset_y[steps.vectors - 1][15], x, y, p);
}

// planChunk for chunks [x_begin / 16, + chunks) of row y, without branches (so that the
// compiler may vectorise it): the same expressions in the same order, so the same
// positions and decisions. Used by the 128-bit kernel.
// Inside interiorChunks' range (Interior) only the positions.
template <bool Interior>
inline void planChunksPortable(const PlaneSpan &src, int channels, const double m[6], const LaneSteps &steps,
                               int x_begin, int chunks, int y, RowPlan &plan, int at)
{
    const double last_x = m[0] * (kChunk - 1), last_y = m[3] * (kChunk - 1);
    const double row_x = m[1] * y, row_y = m[4] * y;
    const double width1 = src.width - 1, height1 = src.height - 1;
    const int last_window = steps.offset_x[steps.vectors - 1][steps.half_pixels * channels];
    const int last_offset_y = steps.offset_y[steps.vectors - 1][15];
    const int row_bytes = src.width * channels;
    for (int c = 0; c < chunks; ++c) {
        const int x = x_begin + c * kChunk;
        const double sx0 = m[0] * x + row_x + m[2];
        const double sy0 = m[3] * x + row_y + m[5];
        const double sx1 = sx0 + last_x, sy1 = sy0 + last_y;
        const bool inside = Interior || ((sx0 >= 0.0) & (sx1 >= 0.0) & (sx0 < width1) & (sx1 < width1) &
                                         (sy0 >= 0.0) & (sy1 >= 0.0) & (sy0 < height1) & (sy1 < height1));
        // Inside, sx0, sy0 >= 0: truncation is the floor, and the position in 1/1024 px
        // (exact) splits into planChunk's integer part and fraction. Outside: any value.
        const double cx = inside ? sx0 : 0.0, cy = inside ? sy0 : 0.0;
        const int qx = int(cx * 1024.0), qy = int(cy * 1024.0);
        const int ix0 = qx >> 10, iy0 = qy >> 10;
        const int frx = qx & 1023, fry = qy & 1023;
        const int ky_last = (fry + last_offset_y) >> 10;
        const int ky_min = std::min(0, ky_last), ky_max = std::max(0, ky_last);
        const bool refused = !Interior && (((ix0 + ((frx + last_window) >> 10)) * channels + 16 > row_bytes) |
                                           (ky_max - ky_min > 1) | (iy0 + ky_max + 1 >= src.height) |
                                           (iy0 + ky_min < 0));
        plan.ix0[at + c] = ix0;
        plan.iy0[at + c] = iy0;
        plan.frx[at + c] = frx;
        plan.fry[at + c] = fry;
        plan.ky_last[at + c] = ky_last;
        plan.vector_ok[at + c] = inside & !refused ? -1 : 0;
    }
}


// One planned chunk's bytes (out: its first pixel), as the vector kernels compute them.
inline void chunkScalar(const PlaneSpan &src, int channels, const LaneSteps &steps, const ChunkPlan &p,
                        std::uint8_t *out)
{
    const std::size_t stride = std::size_t(src.stride);
    for (int v = 0; v < steps.vectors; ++v)
        for (int l = 0; l < 16; ++l) {
            const int rel_x = p.frx + steps.offset_x[v][l], rel_y = p.fry + steps.offset_y[v][l];
            const int kx = rel_x >> 10, ky = rel_y >> 10;
            const int fx = (rel_x >> (10 - kFracBits)) & (kOne - 1);
            const int fy = (rel_y >> (10 - kFracBits)) & (kOne - 1);
            const std::uint8_t *tap =
                src.data + std::size_t(p.iy0 + ky) * stride + (p.ix0 + kx) * channels + steps.channel[l];
            const int t = tap[0] * (kOne - fx) + tap[channels] * fx;
            const int b = tap[stride] * (kOne - fx) + tap[stride + channels] * fx;
            const int value = t + (((b - t) * (fy << 9) + (1 << 14)) >> 15);
            out[v * 16 + l] = std::uint8_t(std::clamp((value + kOne / 2) >> kFracBits, 0, 255));
        }
}

// The reference: what every vector kernel computes, one byte at a time. Lane (v, l) is
// pixel v * 16 / C + l / C, channel l % C: taps at the integer part of its position, weights
// the top 6 bits of the 1/1024 fraction, horizontal blend x64, vertical blend rounded as
// pmulhrsw does ((d * fy * 2^9 + 2^14) >> 15), then (v + 32) >> 6.
template <class Matrices>
void warpRowsScalar(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                    int row_end, int channels, Matrices &matrices, bool replicate, const std::uint8_t border[4])
{
    for (int y = row_begin; y < row_end; ++y) {
        const double *m = matrices.row(y);
        const LaneSteps &steps = matrices.steps();
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        int x = 0;
        for (; x + kChunk <= dst_width; x += kChunk) {
            ChunkPlan p;
            if (!planChunk(src, channels, m, steps, x, y, p)) {
                samplePixels(src, channels, m, replicate, border, out, x, y, kChunk);
                continue;
            }
            chunkScalar(src, channels, steps, p, out + x * channels);
        }
        samplePixels(src, channels, m, replicate, border, out, x, y, dst_width - x);
    }
}

// warpRowsScalar with a matrix per chunk; the columns past the last chunk at the mesh's
// positions.
void warpMeshRowsScalar(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                        int row_end, int channels, MatrixPerChunk &chunks, bool replicate,
                        const std::uint8_t border[4])
{
    const int chunks_in_row = dst_width / kChunk;
    for (int y = row_begin; y < row_end; ++y) {
        chunks.beginRow(y, chunks_in_row);
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        for (int c = 0; c < chunks_in_row; ++c) {
            const int x = c * kChunk;
            double m[6];
            chunks.matrix(c, m);
            ChunkPlan p;
            if (!chunks.vectorOk(c) || !planChunk(src, channels, m, chunks.lastWindow(c), chunks.lastOffsetY(c), x, y, p)) {
                samplePixels(src, channels, m, replicate, border, out, x, y, kChunk);
                continue;
            }
            chunkScalar(src, channels, chunks.steps(c), p, out + x * channels);
        }
        samplePixelsAtMesh(src, channels, chunks.mesh(), replicate, border, out, chunks_in_row * kChunk, y, dst_width);
    }
}

#ifdef UAVSTAB_HAVE_X86

__attribute__((target("avx2"))) void MatrixPerChunk::beginRowNodesAvx2(int y)
{
    int j;
    double t;
    mesh_.rowCell(y, j, t);
    const std::size_t columns = std::size_t(mesh_.columns);
    const double *top_x = mesh_.x.data() + std::size_t(j) * columns, *top_y = mesh_.y.data() + std::size_t(j) * columns;
    const double *bottom_x = top_x + columns, *bottom_y = top_y + columns;
    const __m256d tv = _mm256_set1_pd(t);
    std::size_t i = 0;
    // rowAt's expressions.
    for (; i + 4 <= columns; i += 4) {
        const __m256d tx = _mm256_loadu_pd(top_x + i), ty = _mm256_loadu_pd(top_y + i);
        _mm256_storeu_pd(row_x_.data() + i, _mm256_add_pd(tx, _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(bottom_x + i), tx), tv)));
        _mm256_storeu_pd(row_y_.data() + i, _mm256_add_pd(ty, _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(bottom_y + i), ty), tv)));
    }
    for (; i < columns; ++i) {
        row_x_[i] = top_x[i] + (bottom_x[i] - top_x[i]) * t;
        row_y_[i] = top_y[i] + (bottom_y[i] - top_y[i]) * t;
    }
}

// A double mask's four 64-bit lanes as 32-bit ones.
__attribute__((target("avx2"))) inline __m128i mask32(__m256d mask)
{
    return _mm256_castsi256_si128(
        _mm256_permutevar8x32_epi32(_mm256_castpd_si256(mask), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
}

// roundStep of four doubles.
__attribute__((target("avx2"))) inline __m128i roundSteps(__m256d v)
{
    const __m128i i = _mm256_cvttpd_epi32(v);
    const __m256d f = _mm256_sub_pd(v, _mm256_cvtepi32_pd(i));
    // i + (f >= 0.5) - (f <= -0.5): a true mask is -1.
    return _mm_add_epi32(_mm_sub_epi32(i, mask32(_mm256_cmp_pd(f, _mm256_set1_pd(0.5), _CMP_GE_OQ))),
                         mask32(_mm256_cmp_pd(f, _mm256_set1_pd(-0.5), _CMP_LE_OQ)));
}

// offsetX, offsetY of four steps for pixel j.
__attribute__((target("avx2"))) inline __m128i offsetsX(__m128i step, int j)
{
    return _mm_srai_epi32(_mm_add_epi32(_mm_mullo_epi32(step, _mm_set1_epi32(j)), _mm_set1_epi32(1 << 14)), 15);
}

__attribute__((target("avx2"))) inline __m128i offsetsY(__m128i step, int j)
{
    const __m128i r = _mm_srli_epi32(
        _mm_add_epi32(_mm_mullo_epi32(_mm_abs_epi32(step), _mm_set1_epi32(j << 6)), _mm_set1_epi32(1 << 14)), 15);
    return _mm_sign_epi32(r, step);
}

// A 16-bit value in both halves of each 32-bit lane.
__attribute__((target("avx2"))) inline __m128i twice16(__m128i v)
{
    return _mm_or_si128(_mm_and_si128(v, _mm_set1_epi32(0xffff)), _mm_slli_epi32(v, 16));
}

// planChunk's tests of four chunks (the operations of planChunksAvx2<false>, lane by lane
// the same as planChunk's) from their first pixels' positions, their last pixels' offsets
// from them and their steps (stepOfM0, stepOfM3), into plan entries [at, at + 4) with the rest of
// MeshPlan's. `taken`: the chunks the window trick takes at all (else refused whatever
// their plan; their steps are 0).
template <int C>
__attribute__((target("avx2"), always_inline)) inline void planMeshFour(const PlaneSpan &src, __m256d sx0,
                                                                       __m256d sy0, __m256d last_x, __m256d last_y,
                                                                       __m128i step_x, __m128i step_y,
                                                                       __m128i taken, MeshPlan &plan, int at)
{
    constexpr int channels = C;
    const __m256d zero = _mm256_setzero_pd();
    const __m256d width1 = _mm256_set1_pd(double(src.width - 1)), height1 = _mm256_set1_pd(double(src.height - 1));
    const __m256d k1024 = _mm256_set1_pd(1024.0);
    const __m128i fraction = _mm_set1_epi32(1023);
    const __m128i row_bytes = _mm_set1_epi32(src.width * channels - 16);
    const __m128i height = _mm_set1_epi32(src.height), one = _mm_set1_epi32(1), zero_i = _mm_setzero_si128();
    const __m128i last_window = offsetsX(step_x, lanePixel(C, C - 1, 8));
    const __m128i last_offset_y = offsetsY(step_y, lanePixel(C, C - 1, 15));
    const __m128i qx = _mm256_cvttpd_epi32(_mm256_mul_pd(sx0, k1024));
    const __m128i qy = _mm256_cvttpd_epi32(_mm256_mul_pd(sy0, k1024));
    const __m128i ix0 = _mm_srai_epi32(qx, 10), iy0 = _mm_srai_epi32(qy, 10);
    const __m128i frx = _mm_and_si128(qx, fraction), fry = _mm_and_si128(qy, fraction);
    const __m128i ky_last = _mm_srai_epi32(_mm_add_epi32(fry, last_offset_y), 10);
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.ix0 + at), ix0);
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.iy0 + at), iy0);
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.ky_last + at), ky_last);
    const __m256d sx1 = _mm256_add_pd(sx0, last_x), sy1 = _mm256_add_pd(sy0, last_y);
    const __m256d inside = _mm256_and_pd(
        _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(sx0, zero, _CMP_GE_OQ), _mm256_cmp_pd(sx1, zero, _CMP_GE_OQ)),
                      _mm256_and_pd(_mm256_cmp_pd(sx0, width1, _CMP_LT_OQ), _mm256_cmp_pd(sx1, width1, _CMP_LT_OQ))),
        _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(sy0, zero, _CMP_GE_OQ), _mm256_cmp_pd(sy1, zero, _CMP_GE_OQ)),
                      _mm256_and_pd(_mm256_cmp_pd(sy0, height1, _CMP_LT_OQ), _mm256_cmp_pd(sy1, height1, _CMP_LT_OQ))));
    const __m128i ky_min = _mm_min_epi32(zero_i, ky_last), ky_max = _mm_max_epi32(zero_i, ky_last);
    const __m128i window_end =
        _mm_mullo_epi32(_mm_add_epi32(ix0, _mm_srai_epi32(_mm_add_epi32(frx, last_window), 10)),
                        _mm_set1_epi32(channels));
    const __m128i refused = _mm_or_si128(
        _mm_or_si128(_mm_cmpgt_epi32(window_end, row_bytes), _mm_cmpgt_epi32(_mm_sub_epi32(ky_max, ky_min), one)),
        _mm_or_si128(_mm_cmpgt_epi32(_mm_add_epi32(_mm_add_epi32(iy0, ky_max), one), _mm_sub_epi32(height, one)),
                     _mm_cmpgt_epi32(zero_i, _mm_add_epi32(iy0, ky_min))));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.vector_ok + at),
                     _mm_and_si128(taken, _mm_andnot_si128(refused, mask32(inside))));
    // What the kernel broadcasts.
    const __m128i step_x_b = _mm_srai_epi32(_mm_add_epi32(step_x, _mm_set1_epi32(1 << 14)), 15);
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.frx2 + at), twice16(frx));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.fry2 + at), twice16(fry));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.step_x_b2 + at), twice16(step_x_b));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.step_x_a2 + at),
                     twice16(_mm_sub_epi32(step_x, _mm_slli_epi32(step_x_b, 15))));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.step_y_abs2 + at), twice16(_mm_abs_epi32(step_y)));
    _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.step_y_sign2 + at),
                     _mm_or_si128(_mm_cmpgt_epi32(zero_i, step_y), _mm_set1_epi32(0x00010001)));
    for (int v = 0; v < C; ++v)
        for (int h = 0; h < 2; ++h) {
            const __m128i k = _mm_srai_epi32(_mm_add_epi32(frx, offsetsX(step_x, lanePixel(C, v, 8 * h))), 10);
            const __m128i pixel = _mm_add_epi32(ix0, k);
            _mm_storeu_si128(reinterpret_cast<__m128i *>(plan.window_byte[v * 2 + h] + at),
                             C == 2 ? _mm_add_epi32(pixel, pixel) : pixel);
        }
}

// The plan of chunks [first, first + count) of a mesh row in one-chunk cells, four at a
// time, from the row's nodes (beginRowNodesAvx2): each chunk's matrix, steps and tests in
// the operations of MatrixPerChunk::setChunk and planChunk, so the same entries and
// decisions (m1 = m4 = 0: planChunk's m1 y adds zero, as here).
template <int C>
__attribute__((target("avx2"))) inline void planMeshRowAvx2(const PlaneSpan &src, const MatrixPerChunk &chunks,
                                                            MeshPlan &plan, int first, int count)
{
    const __m256d inv_cell = _mm256_set1_pd(1.0 / kChunk);  // exact: as the division
    const __m256d zero = _mm256_setzero_pd(), max_m0 = _mm256_set1_pd(1.25), max_slope = _mm256_set1_pd(0.9);
    const __m256d last = _mm256_set1_pd(double(kChunk - 1)), sign_bit = _mm256_set1_pd(-0.0);
    const __m256d scale_x = _mm256_set1_pd(double(1 << kStepXBits)), scale_y = _mm256_set1_pd(double(1 << kStepYBits));
    const __m128i fits = _mm_set1_epi32(chunks.windowFits() ? -1 : 0);
    const double *row_x = chunks.rowX(), *row_y = chunks.rowY();
    for (int c = 0; c < count; c += 4) {
        const int k = first + c;
        const __m256d xs = _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(k * kChunk), _mm_setr_epi32(0, 16, 32, 48)));
        const __m256d ax = _mm256_loadu_pd(row_x + k), bx = _mm256_loadu_pd(row_x + k + 1);
        const __m256d ay = _mm256_loadu_pd(row_y + k), by = _mm256_loadu_pd(row_y + k + 1);
        const __m256d m0 = _mm256_mul_pd(_mm256_sub_pd(bx, ax), inv_cell);
        const __m256d m3 = _mm256_mul_pd(_mm256_sub_pd(by, ay), inv_cell);
        const __m256d m2 = _mm256_sub_pd(ax, _mm256_mul_pd(m0, xs)), m5 = _mm256_sub_pd(ay, _mm256_mul_pd(m3, xs));
        const __m256d slope = _mm256_mul_pd(_mm256_andnot_pd(sign_bit, m3), last);
        const __m256d ok_d = _mm256_and_pd(
            _mm256_and_pd(_mm256_cmp_pd(m0, zero, _CMP_GT_OQ), _mm256_cmp_pd(m0, max_m0, _CMP_LE_OQ)),
            _mm256_cmp_pd(slope, max_slope, _CMP_LE_OQ));
        const __m128i ok = _mm_and_si128(fits, mask32(ok_d));
        const __m128i step_x = _mm_and_si128(ok, roundSteps(_mm256_mul_pd(m0, scale_x)));
        const __m128i step_y = _mm_and_si128(ok, roundSteps(_mm256_mul_pd(m3, scale_y)));
        const __m256d sx0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m0, xs), zero), m2);
        const __m256d sy0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m3, xs), zero), m5);
        planMeshFour<C>(src, sx0, sy0, _mm256_mul_pd(m0, last), _mm256_mul_pd(m3, last), step_x, step_y, ok, plan, c);
    }
}

// The same for any cell from the row's entries (MatrixPerChunk::beginRow; its last window
// and last offset are offsetsX's and offsetsY's of its steps).
template <int C>
__attribute__((target("avx2"))) inline void planMeshChunksAvx2(const PlaneSpan &src, const MatrixPerChunk &chunks,
                                                               MeshPlan &plan, int first, int count)
{
    const __m256d zero = _mm256_setzero_pd(), last = _mm256_set1_pd(double(kChunk - 1));
    const __m128i zero_i = _mm_setzero_si128();
    for (int c = 0; c < count; c += 4) {
        const int k = first + c;
        const __m256d m0 = _mm256_loadu_pd(chunks.m0() + k), m3 = _mm256_loadu_pd(chunks.m3() + k);
        const __m256d m2 = _mm256_loadu_pd(chunks.m2() + k), m5 = _mm256_loadu_pd(chunks.m5() + k);
        const __m256d xs = _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(k * kChunk), _mm_setr_epi32(0, 16, 32, 48)));
        const __m256d sx0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m0, xs), zero), m2);
        const __m256d sy0 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m3, xs), zero), m5);
        const __m128i taken = _mm_cmpgt_epi32(
            _mm_loadu_si128(reinterpret_cast<const __m128i *>(chunks.vectorOks() + k)), zero_i);
        planMeshFour<C>(src, sx0, sy0, _mm256_mul_pd(m0, last), _mm256_mul_pd(m3, last),
                        _mm_loadu_si128(reinterpret_cast<const __m128i *>(chunks.stepsX() + k)),
                        _mm_loadu_si128(reinterpret_cast<const __m128i *>(chunks.stepsY() + k)), taken, plan, c);
    }
}

// What the bytes of one vector of a mesh chunk need besides its source rows: taps,
// weights and rows from its plan (MeshPlan), with chunkVectorAvx2's arithmetic. The same
// for every plane warped through the mesh's plan.
struct MeshVectorTaps {
    __m256i ctrl, wx, fy_scaled;
    __m256i lower_row;  // the lanes whose taps sit one source row further down (ky_last != 0)
    int byte0, byte1;   // where each half's window starts in its source rows
    int first_row;      // the chunk's first source row
    bool two_rows;
};

template <int C>
__attribute__((target("avx2"), always_inline)) inline MeshVectorTaps meshVectorTaps(
    const Avx2Lanes &lanes, __m256i offset_x, __m256i offset_y, __m256i window, __m256i frx_v, __m256i fry_v,
    int byte0, int byte1, int iy0, int ky_last)
{
    MeshVectorTaps taps;
    const __m256i rel_x = _mm256_add_epi16(frx_v, offset_x);
    const __m256i rel_y = _mm256_add_epi16(fry_v, offset_y);
    const __m256i kx = _mm256_srli_epi16(rel_x, 10);
    const __m256i fx = _mm256_and_si256(_mm256_srli_epi16(rel_x, 10 - kFracBits), lanes.frac_mask);
    const __m256i fy = _mm256_and_si256(_mm256_srai_epi16(rel_y, 10 - kFracBits), lanes.frac_mask);
    const __m256i window_k = _mm256_srli_epi16(_mm256_add_epi16(frx_v, window), 10);
    __m256i left = _mm256_sub_epi16(kx, window_k);
    if (C == 2) {
        left = _mm256_add_epi16(left, left);
        left = _mm256_add_epi16(left, lanes.channel);
    }
    taps.ctrl = _mm256_add_epi16(left, _mm256_add_epi16(_mm256_slli_epi16(left, 8), lanes.next_tap));
    taps.wx = _mm256_or_si256(_mm256_sub_epi16(lanes.one, fx), _mm256_slli_epi16(fx, 8));
    taps.fy_scaled = _mm256_slli_epi16(fy, 9);
    taps.two_rows = ky_last != 0;
    taps.lower_row = taps.two_rows ? _mm256_cmpeq_epi16(_mm256_srai_epi16(rel_y, 10),
                                                        _mm256_set1_epi16(std::int16_t(std::max(0, ky_last))))
                                   : _mm256_setzero_si256();
    taps.byte0 = byte0;
    taps.byte1 = byte1;
    taps.first_row = iy0 + std::min(0, ky_last);
    return taps;
}

// That vector's 16 values (16-bit lanes, not yet packed) from one plane's source rows.
__attribute__((target("avx2"), always_inline)) inline __m256i meshVectorValues(const std::uint8_t *src_data,
                                                                               std::size_t stride,
                                                                               const MeshVectorTaps &taps)
{
    const std::uint8_t *row = src_data + std::size_t(taps.first_row) * stride;
    __m256i value = interpolateRows(row, row + stride, taps.byte0, taps.byte1, taps.ctrl, taps.wx, taps.fy_scaled);
    if (taps.two_rows) {
        const __m256i lower =
            interpolateRows(row + stride, row + 2 * stride, taps.byte0, taps.byte1, taps.ctrl, taps.wx, taps.fy_scaled);
        value = _mm256_blendv_epi8(value, lower, taps.lower_row);
    }
    return _mm256_srli_epi16(_mm256_add_epi16(value, _mm256_set1_epi16(kOne / 2)), kFracBits);
}

// warpRowsAvx2 with a matrix per chunk: the row's chunks planned with their own matrices
// (planMeshRowAvx2, planMeshChunksAvx2), their bytes with their own offsets. P planes of
// one geometry through one mesh (I420's chroma planes) share the plan and the taps, so
// that each writes the bytes it would alone.
template <int C, int P>
__attribute__((target("avx2"))) void warpMeshRowsAvx2(const MeshWarpPlane (&planes)[P], int dst_width, int row_begin,
                                                      int row_end, MatrixPerChunk &chunks, bool replicate)
{
    constexpr int channels = C;
    const PlaneSpan &src = planes[0].src;  // the geometry the plan is made for
    Avx2Lanes lanes;
    lanes.channel = _mm256_load_si256(reinterpret_cast<const __m256i *>(chunks.layout().channel));
    lanes.high_mask = _mm256_sub_epi16(
        _mm256_setzero_si256(), _mm256_load_si256(reinterpret_cast<const __m256i *>(chunks.layout().is_high_half)));
    lanes.frac_mask = _mm256_set1_epi16(kOne - 1);
    lanes.one = _mm256_set1_epi16(kOne);
    lanes.next_tap = _mm256_set1_epi16(std::int16_t(channels << 8));
    // offsetX, offsetY for the 16 lanes of vector v in 16-bit lanes: the lanes' pixels j and
    // j 2^6.
    __m256i pixel[C], pixel_y[C];
    for (int v = 0; v < C; ++v) {
        alignas(32) std::int16_t j[16], jy[16];
        for (int l = 0; l < 16; ++l) {
            j[l] = std::int16_t(lanePixel(C, v, l));
            jy[l] = std::int16_t(lanePixel(C, v, l) << 6);
        }
        pixel[v] = _mm256_load_si256(reinterpret_cast<const __m256i *>(j));
        pixel_y[v] = _mm256_load_si256(reinterpret_cast<const __m256i *>(jy));
    }
    // Byte shuffle control: each 128-bit half's first 16-bit lane in all its lanes.
    const __m256i first_lane = _mm256_set1_epi16(0x0100);
    const int chunks_in_row = dst_width / kChunk;
    const bool one_chunk_cells = chunks.mesh().cell == kChunk;
    const int per_cell = chunks.mesh().cell / kChunk;
    MeshPlan plan;
    // Chunk c's vector v's taps. Its lane offsets are recomputed for every chunk (in a mesh
    // of 16-px cells the steps seldom repeat) from the plan's broadcast values: two 16-bit
    // multiplies for x, one for y.
    const auto vectorTaps = [&](int c, int v) __attribute__((target("avx2"), always_inline)) {
        // j b + ((j a + 2^14) >> 15) = (j (b 2^15 + a) + 2^14) >> 15.
        const __m256i offset_x =
            _mm256_add_epi16(_mm256_mullo_epi16(pixel[v], _mm256_set1_epi32(plan.step_x_b2[c])),
                             _mm256_mulhrs_epi16(pixel[v], _mm256_set1_epi32(plan.step_x_a2[c])));
        const __m256i offset_y = _mm256_sign_epi16(
            _mm256_mulhrs_epi16(pixel_y[v], _mm256_set1_epi32(plan.step_y_abs2[c])), _mm256_set1_epi32(plan.step_y_sign2[c]));
        return meshVectorTaps<C>(lanes, offset_x, offset_y, _mm256_shuffle_epi8(offset_x, first_lane),
                                 _mm256_set1_epi32(plan.frx2[c]), _mm256_set1_epi32(plan.fry2[c]),
                                 plan.window_byte[2 * v][c], plan.window_byte[2 * v + 1][c], plan.iy0[c],
                                 plan.ky_last[c]);
    };
    for (int y = row_begin; y < row_end; ++y) {
        if (one_chunk_cells) {
            chunks.beginRowNodesAvx2(y);
        } else {
            cleanUpperHalves();
            chunks.beginRow(y, chunks_in_row);
        }
        std::uint8_t *out[P];
        for (int q = 0; q < P; ++q)
            out[q] = planes[q].dst + std::size_t(y) * planes[q].dst_stride;
        for (int first = 0; first < chunks_in_row; first += kPlanChunks) {
            const int count = std::min(kPlanChunks, chunks_in_row - first);
            if (one_chunk_cells)
                planMeshRowAvx2<C>(src, chunks, plan, first, count);
            else
                planMeshChunksAvx2<C>(src, chunks, plan, first, count);
            for (int q = 0; q < P; ++q)
                prefetchBelow(planes[q].src, channels, plan, count);
            for (int c = 0; c < count; ++c) {
                const int k = first + c, x = k * kChunk;
                if (!plan.vector_ok[c]) {
                    double m[6];
                    chunks.chunkMatrix(k / per_cell, m);
                    cleanUpperHalves();
                    for (int q = 0; q < P; ++q)
                        samplePixels(planes[q].src, channels, m, replicate, planes[q].border, out[q], x, y, kChunk);
                    continue;
                }
                if (C == 1 && c + 2 <= count && (plan.vector_ok[c] & plan.vector_ok[c + 1])) {
                    // Two chunks' vectors packed into one 32-byte store.
                    const MeshVectorTaps a = vectorTaps(c, 0), b = vectorTaps(c + 1, 0);
                    for (int q = 0; q < P; ++q) {
                        const std::size_t stride = std::size_t(planes[q].src.stride);
                        const __m256i va = meshVectorValues(planes[q].src.data, stride, a);
                        const __m256i vb = meshVectorValues(planes[q].src.data, stride, b);
                        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out[q] + x),
                                            _mm256_permute4x64_epi64(_mm256_packus_epi16(va, vb), 0xD8));
                    }
                    ++c;
                    continue;
                }
                MeshVectorTaps taps[C];
                for (int v = 0; v < C; ++v)
                    taps[v] = vectorTaps(c, v);
                for (int q = 0; q < P; ++q) {
                    const std::size_t stride = std::size_t(planes[q].src.stride);
                    __m256i vectors[C];
                    for (int v = 0; v < C; ++v)
                        vectors[v] = meshVectorValues(planes[q].src.data, stride, taps[v]);
                    const __m256i packed =
                        _mm256_permute4x64_epi64(_mm256_packus_epi16(vectors[0], vectors[C - 1]), 0xD8);
                    if (C == 2)
                        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out[q] + x * channels), packed);
                    else
                        _mm_storeu_si128(reinterpret_cast<__m128i *>(out[q] + x * channels),
                                         _mm256_castsi256_si128(packed));
                }
            }
        }
        if (chunks_in_row * kChunk < dst_width) {
            cleanUpperHalves();
            for (int q = 0; q < P; ++q)
                samplePixelsAtMesh(planes[q].src, channels, chunks.mesh(), replicate, planes[q].border, out[q],
                                   chunks_in_row * kChunk, y, dst_width);
        }
    }
    cleanUpperHalves();
}

#endif // UAVSTAB_HAVE_X86

#ifdef UAVSTAB_HAVE_SIMD128

// The 128-bit kernel is warpRowsAvx2 one 128-bit half at a time, written once with
// OpenCV's universal intrinsics. Why these rather than Google Highway: OpenCV is already a
// dependency (no new package in the CI, debian/control or the arm64 sysroot), the same
// source compiles to SSE2 on x86-64 and NEON on aarch64, and the AVX2 kernel, measured and
// proven, stays as it is, so x86 with AVX2 runs exactly the code it ran before (dispatch:
// AVX2 > 128-bit > scalar). The intrinsics have no register byte shuffle, the heart of the
// window trick, nor pmulhrsw: those two are spelt per ISA here (and make the x86 version
// need SSSE3, checked at run time).
using cv::v_int16x8;
using cv::v_uint16x8;
using cv::v_uint8x16;

UAVSTAB_TARGET_SIMD128 inline v_uint8x16 lookupBytes(const v_uint8x16 &table, const v_uint8x16 &index)
{
#if defined(UAVSTAB_HAVE_X86)
    return v_uint8x16(_mm_shuffle_epi8(table.val, index.val));
#elif defined(__aarch64__)
    return v_uint8x16(vqtbl1q_u8(table.val, index.val));
#else
    const uint8x8x2_t t = {{vget_low_u8(table.val), vget_high_u8(table.val)}};
    return v_uint8x16(vcombine_u8(vtbl2_u8(t, vget_low_u8(index.val)), vtbl2_u8(t, vget_high_u8(index.val))));
#endif
}

// (a * b + 2^14) >> 15 per 16-bit lane: pmulhrsw, and on NEON vqrdmulh ((2ab + 2^15) >> 16,
// the same; it saturates only for a = b = -32768, and b = fy << 9 >= 0 here).
UAVSTAB_TARGET_SIMD128 inline v_int16x8 mulRoundShift15(const v_int16x8 &a, const v_int16x8 &b)
{
#if defined(UAVSTAB_HAVE_X86)
    return v_int16x8(_mm_mulhrs_epi16(a.val, b.val));
#else
    return v_int16x8(vqrdmulhq_s16(a.val, b.val));
#endif
}

// Horizontal taps of two source rows, then the vertical blend (8 lanes, x64): as
// interpolateRows.
UAVSTAB_TARGET_SIMD128 inline v_int16x8 interpolateRows128(const std::uint8_t *top, const std::uint8_t *bottom,
                                                            const v_uint8x16 &ctrl, const v_int16x8 &w_left,
                                                            const v_int16x8 &w_right, const v_int16x8 &fy_scaled)
{
    const v_uint16x8 low_byte = cv::v_setall_u16(0xff);
    const v_uint16x8 tp = cv::v_reinterpret_as_u16(lookupBytes(cv::v_load(top), ctrl));
    const v_uint16x8 bp = cv::v_reinterpret_as_u16(lookupBytes(cv::v_load(bottom), ctrl));
    const v_int16x8 t = cv::v_mul_wrap(cv::v_reinterpret_as_s16(tp & low_byte), w_left) +
                        cv::v_mul_wrap(cv::v_reinterpret_as_s16(tp >> 8), w_right);
    const v_int16x8 b = cv::v_mul_wrap(cv::v_reinterpret_as_s16(bp & low_byte), w_left) +
                        cv::v_mul_wrap(cv::v_reinterpret_as_s16(bp >> 8), w_right);
    return t + mulRoundShift15(b - t, fy_scaled);
}

// One planned chunk's bytes (out: its first pixel): each 128-bit half reads one 16-byte
// window per source row it crosses, as chunkVectorAvx2.
template <int C>
UAVSTAB_TARGET_SIMD128 inline void chunk128(const std::uint8_t *src_data, std::size_t stride, const LaneSteps &steps,
                                            int ix0, int iy0, int frx, int fry, int ky_last, std::uint8_t *out)
{
    constexpr int channels = C;
    const v_int16x8 frac_mask = cv::v_setall_s16(kOne - 1);
    const v_int16x8 one = cv::v_setall_s16(kOne);
    const v_int16x8 round = cv::v_setall_s16(kOne / 2);
    const v_int16x8 next_tap = cv::v_setall_s16(std::int16_t(channels << 8));
    const int ky_min = std::min(0, ky_last), ky_max = std::max(0, ky_last);
    const std::uint8_t *row = src_data + std::size_t(iy0 + ky_min) * stride;
    const v_int16x8 frx_v = cv::v_setall_s16(std::int16_t(frx));
    const v_int16x8 fry_v = cv::v_setall_s16(std::int16_t(fry));
    const v_int16x8 ky_step = cv::v_setall_s16(std::int16_t(ky_max));
    for (int v = 0; v < C; ++v) {
        v_int16x8 result[2];
        for (int h = 0; h < 2; ++h) {
            const std::int16_t *ox = steps.offset_x[v] + 8 * h;
            const v_int16x8 rel_x = frx_v + cv::v_load(ox);
            const v_int16x8 rel_y = fry_v + cv::v_load(steps.offset_y[v] + 8 * h);
            // The half reads a window that starts at its first pixel's left tap.
            const int k = (frx + ox[0]) >> 10;
            const v_int16x8 kx = rel_x >> 10;  // rel_x >= 0
            const v_int16x8 fx = (rel_x >> (10 - kFracBits)) & frac_mask;
            const v_int16x8 fy_scaled = ((rel_y >> (10 - kFracBits)) & frac_mask) << 9;
            v_int16x8 left = kx - cv::v_setall_s16(std::int16_t(k));
            if (C == 2)
                left = left + left;
            left = left + cv::v_load(steps.channel + 8 * h);
            const v_uint8x16 ctrl = cv::v_reinterpret_as_u8(left + ((left << 8) + next_tap));
            const std::size_t byte = std::size_t(ix0 + k) * channels;
            v_int16x8 value =
                interpolateRows128(row + byte, row + stride + byte, ctrl, one - fx, fx, fy_scaled);
            if (ky_max != ky_min) {
                const v_int16x8 lower = interpolateRows128(row + stride + byte, row + 2 * stride + byte,
                                                           ctrl, one - fx, fx, fy_scaled);
                value = cv::v_select((rel_y >> 10) == ky_step, lower, value);
            }
            result[h] = (value + round) >> kFracBits;  // value >= 0
        }
        cv::v_store(out + v * 16, cv::v_pack_u(result[0], result[1]));
    }
}

template <int C, class Matrices>
UAVSTAB_TARGET_SIMD128 void warpRows128(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width,
                                        int row_begin, int row_end, Matrices &matrices, bool replicate,
                                        const std::uint8_t border[4])
{
    constexpr int channels = C;
    const std::size_t stride = std::size_t(src.stride);
    RowPlan plan;
    for (int y = row_begin; y < row_end; ++y) {
        const double *m = matrices.row(y);
        const LaneSteps &steps = matrices.steps();
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        const int chunks_in_row = dst_width / kChunk;
        const ChunkRange interior = interiorChunks(src, channels, m, steps, y, chunks_in_row);
        for (int first = 0; first < chunks_in_row; first += kPlanChunks) {
            const int chunks = std::min(kPlanChunks, chunks_in_row - first);
            const int lo = std::clamp(interior.lo - first, 0, chunks), hi = std::clamp(interior.hi - first, lo, chunks);
            planChunksPortable<false>(src, channels, m, steps, first * kChunk, lo, y, plan, 0);
            planChunksPortable<true>(src, channels, m, steps, (first + lo) * kChunk, hi - lo, y, plan, lo);
            planChunksPortable<false>(src, channels, m, steps, (first + hi) * kChunk, chunks - hi, y, plan, hi);
            for (int c = 0; c < chunks; ++c) {
                const int x = (first + c) * kChunk;
                if (!plan.vector_ok[c]) {
                    samplePixels(src, channels, m, replicate, border, out, x, y, kChunk);
                    continue;
                }
                chunk128<C>(src.data, stride, steps, plan.ix0[c], plan.iy0[c], plan.frx[c], plan.fry[c],
                            plan.ky_last[c], out + x * channels);
            }
        }
        const int x = chunks_in_row * kChunk;
        samplePixels(src, channels, m, replicate, border, out, x, y, dst_width - x);
    }
}

// warpRows128 with a matrix per chunk, as warpMeshRowsAvx2.
template <int C>
UAVSTAB_TARGET_SIMD128 void warpMeshRows128(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width,
                                            int row_begin, int row_end, MatrixPerChunk &chunks, bool replicate,
                                            const std::uint8_t border[4])
{
    const std::size_t stride = std::size_t(src.stride);
    const int chunks_in_row = dst_width / kChunk;
    for (int y = row_begin; y < row_end; ++y) {
        chunks.beginRow(y, chunks_in_row);
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        for (int c = 0; c < chunks_in_row; ++c) {
            const int x = c * kChunk;
            double m[6];
            chunks.matrix(c, m);
            ChunkPlan p;
            if (!chunks.vectorOk(c) || !planChunk(src, C, m, chunks.lastWindow(c), chunks.lastOffsetY(c), x, y, p)) {
                samplePixels(src, C, m, replicate, border, out, x, y, kChunk);
                continue;
            }
            chunk128<C>(src.data, stride, chunks.steps(c), p.ix0, p.iy0, p.frx, p.fry, p.ky_min + p.ky_max,
                        out + x * C);
        }
        samplePixelsAtMesh(src, C, chunks.mesh(), replicate, border, out, chunks_in_row * kChunk, y, dst_width);
    }
}

bool cpuHasSimd128()
{
#ifdef UAVSTAB_HAVE_X86
    static const bool has = __builtin_cpu_supports("ssse3");
    return has;
#else
    return true;
#endif
}

#endif // UAVSTAB_HAVE_SIMD128

template <bool Swap>
inline std::uint16_t load16(const std::uint8_t *p)
{
    std::uint16_t v;
    std::memcpy(&v, p, 2);
    return Swap ? std::uint16_t((v >> 8) | (v << 8)) : v;
}

template <bool Swap>
inline void store16(std::uint8_t *p, std::uint16_t v)
{
    if (Swap)
        v = std::uint16_t((v >> 8) | (v << 8));
    std::memcpy(p, &v, 2);
}

// One 16-bit output pixel, any position: taps outside the frame read the border or the
// nearest edge sample.
template <bool Swap>
inline void samplePixel16(const PlaneSpan &src, bool replicate, std::uint16_t border, std::uint8_t *out, double sx,
                          double sy)
{
    const auto at = [&](long x, long y) { return load16<Swap>(src.data + y * src.stride + x * 2); };
    const auto tap = [&](long x, long y) -> double {
        if (x >= 0 && y >= 0 && x < src.width && y < src.height)
            return at(x, y);
        if (!replicate)
            return border;
        return at(std::clamp(x, 0L, long(src.width) - 1), std::clamp(y, 0L, long(src.height) - 1));
    };
    const double max_x = src.width + 1.0, max_y = src.height + 1.0;
    if (!(sx >= -2.0 && sy >= -2.0 && sx <= max_x && sy <= max_y)) {
        if (std::isnan(sx) || std::isnan(sy)) {
            store16<Swap>(out, border);
            return;
        }
        // Far outside is as good as just outside (keeps the integer maths in range).
        sx = std::clamp(sx, -2.0, max_x);
        sy = std::clamp(sy, -2.0, max_y);
    }
    // Truncation of a positive number is its floor (std::floor is a call on plain x86-64).
    const long ix = long(sx + 2.0) - 2, iy = long(sy + 2.0) - 2;
    const double fx = sx - double(ix), fy = sy - double(iy);
    const double p00 = tap(ix, iy), p01 = tap(ix + 1, iy), p10 = tap(ix, iy + 1), p11 = tap(ix + 1, iy + 1);
    const double t = p00 + (p01 - p00) * fx;
    const double b = p10 + (p11 - p10) * fx;
    const double v = t + (b - t) * fy;
    // v lies between the taps (>= 0): truncating v + 0.5 rounds to the nearest count.
    store16<Swap>(out, std::uint16_t(std::min(long(v + 0.5), 65535L)));
}

// matrixOf(y): row y's matrix.
template <bool Swap, class MatrixOf>
void warpRows16(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin, int row_end,
                MatrixOf matrixOf, bool replicate, std::uint16_t border)
{
    const auto general = [&](std::uint8_t *out, double sx, double sy) {
        samplePixel16<Swap>(src, replicate, border, out, sx, sy);
    };
    // Output columns [lo, hi) of a row whose source lies in [0, limit - 1) along one axis
    // (s = a * x + c), a little inside so that rounding cannot take a tap out.
    const auto inside = [dst_width](double a, double c, int limit, int &lo, int &hi) {
        constexpr double kEps = 1e-6;
        const double low = kEps, high = limit - 1 - kEps;
        if (high < low) {
            lo = hi = 0;
            return;
        }
        if (a == 0.0) {
            if (!(c >= low && c <= high))
                lo = hi = 0;
            return;
        }
        double x0 = (low - c) / a, x1 = (high - c) / a;
        if (x0 > x1)
            std::swap(x0, x1);
        lo = std::max(lo, int(std::clamp(std::ceil(x0), 0.0, double(dst_width))));
        hi = std::min(hi, int(std::clamp(std::floor(x1) + 1.0, 0.0, double(dst_width))));
    };
    for (int y = row_begin; y < row_end; ++y) {
        const double *m = matrixOf(y);
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        const double row_x = m[1] * y + m[2], row_y = m[4] * y + m[5];
        int lo = 0, hi = dst_width;
        inside(m[0], row_x, src.width, lo, hi);
        inside(m[3], row_y, src.height, lo, hi);
        if (hi < lo)
            hi = lo;
        for (int x = 0; x < lo; ++x)
            general(out + 2 * x, m[0] * x + row_x, m[3] * x + row_y);
        // Every tap inside: no checks. The same arithmetic as general().
        for (int x = lo; x < hi; ++x) {
            const double sx = m[0] * x + row_x, sy = m[3] * x + row_y;
            const long ix = long(sx), iy = long(sy);
            const double fx = sx - double(ix), fy = sy - double(iy);
            const std::uint8_t *top = src.data + iy * src.stride + ix * 2;
            const double p00 = load16<Swap>(top), p01 = load16<Swap>(top + 2);
            const double p10 = load16<Swap>(top + src.stride), p11 = load16<Swap>(top + src.stride + 2);
            const double t = p00 + (p01 - p00) * fx;
            const double b = p10 + (p11 - p10) * fx;
            const double v = t + (b - t) * fy;
            store16<Swap>(out + 2 * x, std::uint16_t(std::min(long(v + 0.5), 65535L)));
        }
        for (int x = std::max(hi, lo); x < dst_width; ++x)
            general(out + 2 * x, m[0] * x + row_x, m[3] * x + row_y);
    }
}


// ---- 4-channel pixels (BGRx, RGBA...): the bytes OpenCV's warpAffine writes ----------------
//
// The 4-channel formats go through cv::warpAffine (INTER_LINEAR, WARP_INVERSE_MAP), whose
// output they keep: this kernel writes exactly those bytes, in one pass and without
// OpenCV's per-block coordinate and weight tables. OpenCV 4's fixed-point path: for output
// pixel (x, y), X = (round((m1 y + m2) 1024) + 16 + round(m0 x 1024)) >> 5 (round half to
// even, as cvRound), likewise Y; taps at (X >> 5, Y >> 5) and one on; weights from the
// 1/32 fractions fx = X & 31, fy = Y & 31, (32 - fx)(32 - fy) 32 and so on (exact in its
// 2^15 table), so value = (sum tap * (32-fx|fx)(32-fy|fy) + 512) >> 10. Taps outside the
// frame read the border value or, with replicate, the nearest edge pixel (remapBilinear).
// The matrix is the one warpGeneral hands OpenCV: shifted to the stripe's first row.

// Plane matrix shifted to the stripe [row_begin, ...), as warpGeneral does before calling
// OpenCV (whose rows then count from 0).
struct CvStripe {
    double m[6];
};

inline CvStripe cvStripe(const double plane_m[6], int row_begin)
{
    CvStripe s;
    std::copy(plane_m, plane_m + 6, s.m);
    s.m[2] += s.m[1] * row_begin;
    s.m[5] += s.m[4] * row_begin;
    return s;
}

inline int cvRoundInt(double v)
{
    return int(std::lrint(v));  // the default rounding mode: half to even, as cvRound
}

// One output pixel at fixed-point position (X, Y) (1/32 px), any position.
// (Out of line: the kernels take it for edge pixels only, and inlining it into the
// single-matrix kernel only makes that kernel longer.)
__attribute__((noinline)) void samplePixelCv4(const PlaneSpan &src, int X, int Y, bool replicate,
                                              const std::uint8_t *border, std::uint8_t *out)
{
    const int sx = std::clamp(X >> 5, -32768, 32767), sy = std::clamp(Y >> 5, -32768, 32767);  // saturate_cast<short>
    const int fx = X & 31, fy = Y & 31;
    const int w[4] = {(32 - fx) * (32 - fy), fx * (32 - fy), (32 - fx) * fy, fx * fy};
    const std::uint8_t *tap[4];
    for (int k = 0; k < 4; ++k) {
        int tx = sx + (k & 1), ty = sy + (k >> 1);
        if (tx >= 0 && ty >= 0 && tx < src.width && ty < src.height) {
            tap[k] = src.data + std::size_t(ty) * src.stride + std::size_t(tx) * 4;
        } else if (replicate) {
            tx = std::clamp(tx, 0, src.width - 1);
            ty = std::clamp(ty, 0, src.height - 1);
            tap[k] = src.data + std::size_t(ty) * src.stride + std::size_t(tx) * 4;
        } else {
            tap[k] = border;
        }
    }
    for (int c = 0; c < 4; ++c) {
        const int s = tap[0][c] * w[0] + tap[1][c] * w[1] + tap[2][c] * w[2] + tap[3][c] * w[3];
        out[c] = std::uint8_t(std::min(255, (s + 512) >> 10));
    }
}

// Whether the 4-channel kernel takes this stripe: finite, and every output pixel's source
// within +-30000 px (affine: the corners bound it), so that no fixed-point value overflows
// or saturates.
bool cv4Handles(const double m[6], int dst_width, int row_begin, int row_end)
{
    for (int k = 0; k < 6; ++k)
        if (!std::isfinite(m[k]))
            return false;
    for (int cy : {row_begin, row_end})
        for (int cx : {0, dst_width}) {
            const double sx = m[0] * cx + m[1] * cy + m[2], sy = m[3] * cx + m[4] * cy + m[5];
            if (!(std::abs(sx) < 30000.0 && std::abs(sy) < 30000.0))
                return false;
        }
    return true;
}

void warpRowsCv4Scalar(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                       int row_end, const double plane_m[6], bool replicate, const std::uint8_t border[4])
{
    const CvStripe s = cvStripe(plane_m, row_begin);
    const double *m = s.m;
    for (int y = row_begin; y < row_end; ++y) {
        const int yy = y - row_begin;
        const int X0 = cvRoundInt((m[1] * yy + m[2]) * 1024) + 16, Y0 = cvRoundInt((m[4] * yy + m[5]) * 1024) + 16;
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        for (int x = 0; x < dst_width; ++x)
            samplePixelCv4(src, (X0 + cvRoundInt(m[0] * x * 1024)) >> 5, (Y0 + cvRoundInt(m[3] * x * 1024)) >> 5,
                           replicate, border, out + 4 * x);
    }
}

#ifdef UAVSTAB_HAVE_X86

// Eight 4-byte output pixels at fixed-point positions X, Y (1/32 px, as samplePixelCv4
// takes them). Pixels whose four taps all lie inside the frame: the taps of each four read
// from one 32-byte window of each source row (a permute) when the four share a source row
// and fit in it, else with a gather. Any other pixel: per pixel. The positions must move
// monotonically along the eight (a linear map rounded).
class Cv4PixelsAvx2 {
public:
    __attribute__((target("avx2"))) Cv4PixelsAvx2(const PlaneSpan &src, bool replicate, const std::uint8_t *border)
        : src_(src), replicate_(replicate), border_(border), base_(reinterpret_cast<const long long *>(src.data))
    {
        w2_ = _mm256_set1_epi32(src.width - 2);
        h2_ = _mm256_set1_epi32(src.height - 2);
        m31_ = _mm256_set1_epi32(31);
        k32_ = _mm256_set1_epi32(32);
        stride_ = _mm_set1_epi32(src.stride);
        pair_bytes_ = _mm256_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15, 0, 4, 1, 5, 2, 6, 3, 7, 8,
                                       12, 9, 13, 10, 14, 11, 15);
        one64_ = _mm256_set1_epi64x(1);
        pixels_a_ = _mm256_setr_epi32(0, 0, 1, 1, 2, 2, 3, 3);
        pixels_b_ = _mm256_setr_epi32(4, 4, 5, 5, 6, 6, 7, 7);
        sixteen_ = _mm256_set1_epi16(16);
    }

    __attribute__((target("avx2"), always_inline)) void operator()(__m256i X, __m256i Y, std::uint8_t *out) const
    {
        const __m256i sx = _mm256_srai_epi32(X, 5), sy = _mm256_srai_epi32(Y, 5);
        // Inside: 0 <= sx <= width - 2 and 0 <= sy <= height - 2 (unsigned compares).
        const __m256i inside = _mm256_and_si256(_mm256_cmpeq_epi32(_mm256_min_epu32(sx, w2_), sx),
                                                _mm256_cmpeq_epi32(_mm256_min_epu32(sy, h2_), sy));
        if (_mm256_movemask_epi8(inside) != -1) {
            alignas(32) int xv[8], yv[8];
            _mm256_store_si256(reinterpret_cast<__m256i *>(xv), X);
            _mm256_store_si256(reinterpret_cast<__m256i *>(yv), Y);
            for (int j = 0; j < 8; ++j)
                samplePixelCv4(src_, xv[j], yv[j], replicate_, border_, out + 4 * j);
            return;
        }
        const __m256i fx = _mm256_and_si256(X, m31_), fy = _mm256_and_si256(Y, m31_);
        // Horizontal weights (32 - fx, fx) as byte pairs and the vertical fy << 10, one
        // pixel per 64-bit lane.
        const __m256i wx1 = _mm256_or_si256(_mm256_sub_epi32(k32_, fx), _mm256_slli_epi32(fx, 8));
        const __m256i wx2 = _mm256_or_si256(wx1, _mm256_slli_epi32(wx1, 16));
        const __m256i fy1 = _mm256_slli_epi32(fy, 10);
        const __m256i fy2 = _mm256_or_si256(fy1, _mm256_slli_epi32(fy1, 16));
        __m256i top, bottom;
        taps(_mm256_castsi256_si128(sx), _mm256_castsi256_si128(sy), top, bottom);
        const __m256i a = blend(top, bottom, _mm256_permutevar8x32_epi32(wx2, pixels_a_),
                                _mm256_permutevar8x32_epi32(fy2, pixels_a_));
        taps(_mm256_extracti128_si256(sx, 1), _mm256_extracti128_si256(sy, 1), top, bottom);
        const __m256i b = blend(top, bottom, _mm256_permutevar8x32_epi32(wx2, pixels_b_),
                                _mm256_permutevar8x32_epi32(fy2, pixels_b_));
        // a: pixels 0 1 | 2 3, b: 4 5 | 6 7 (16-bit) -> bytes 0 1 4 5 | 2 3 6 7 -> 0..7.
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(out), _mm256_permute4x64_epi64(_mm256_packus_epi16(a, b), 0xd8));
    }

private:
    // Left tap and the one on (8 bytes) of four pixels, one per 64-bit lane, in the rows at
    // sy and sy + 1 (sx, sy: the four pixels', inside the frame).
    __attribute__((target("avx2"), always_inline)) void taps(__m128i sx, __m128i sy, __m256i &top,
                                                              __m256i &bottom) const
    {
        const int sx0 = _mm_cvtsi128_si32(sx), sy0 = _mm_cvtsi128_si32(sy);
        const int sx3 = _mm_extract_epi32(sx, 3), sy3 = _mm_extract_epi32(sy, 3);
        // Along a row the source moves monotonically: equal ends share a row, and
        // sx0 <= sx3 makes sx0 the least.
        if (sy0 == sy3 && sx3 >= sx0 && sx3 - sx0 <= 6 && sx0 + 8 <= src_.width) {
            const std::uint8_t *row = src_.data + std::size_t(sy0) * src_.stride + std::size_t(sx0) * 4;
            const __m256i d = _mm256_cvtepu32_epi64(_mm_sub_epi32(sx, _mm_set1_epi32(sx0)));
            const __m256i idx = _mm256_or_si256(d, _mm256_slli_epi64(_mm256_add_epi64(d, one64_), 32));
            top = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i *>(row)), idx);
            bottom = _mm256_permutevar8x32_epi32(
                _mm256_loadu_si256(reinterpret_cast<const __m256i *>(row + src_.stride)), idx);
        } else if (std::abs(sy3 - sy0) == 1 && sx3 >= sx0 && sx3 - sx0 <= 6 && sx0 + 8 <= src_.width) {
            // The four cross one source row (a slanted or bent row of the output): windows
            // of three rows, each pixel's top and bottom tap from the pair at its own row.
            const int first = std::min(sy0, sy3);  // first + 2 <= height - 1: sy <= height - 2
            const std::uint8_t *row = src_.data + std::size_t(first) * src_.stride + std::size_t(sx0) * 4;
            const __m256i d = _mm256_cvtepu32_epi64(_mm_sub_epi32(sx, _mm_set1_epi32(sx0)));
            const __m256i idx = _mm256_or_si256(d, _mm256_slli_epi64(_mm256_add_epi64(d, one64_), 32));
            const __m256i r0 = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i *>(row)), idx);
            const __m256i r1 = _mm256_permutevar8x32_epi32(
                _mm256_loadu_si256(reinterpret_cast<const __m256i *>(row + src_.stride)), idx);
            const __m256i r2 = _mm256_permutevar8x32_epi32(
                _mm256_loadu_si256(reinterpret_cast<const __m256i *>(row + 2 * std::size_t(src_.stride))), idx);
            // Pixels on the second row: sy == first + 1 (in 64-bit lanes).
            const __m256i lower = _mm256_cmpgt_epi64(_mm256_cvtepi32_epi64(sy), _mm256_set1_epi64x(first));
            top = _mm256_blendv_epi8(r0, r1, lower);
            bottom = _mm256_blendv_epi8(r1, r2, lower);
        } else {
            const __m128i offset = _mm_add_epi32(_mm_mullo_epi32(sy, stride_), _mm_slli_epi32(sx, 2));
            top = _mm256_i32gather_epi64(base_, offset, 1);
            bottom = _mm256_i32gather_epi64(base_, _mm_add_epi32(offset, stride_), 1);
        }
    }
    // Four pixels' bytes (16-bit lanes) from their taps and weights: t and b the two rows'
    // horizontal blends (x32, exact), then ((32 - fy) t + fy b + 512) >> 10 =
    // (t + floor(fy (b - t) / 32) + 16) >> 5 (the same integer), the floor a mulhi of
    // 2 (b - t) by fy << 10.
    __attribute__((target("avx2"))) __m256i blend(__m256i top, __m256i bottom, __m256i wx, __m256i fy_scaled) const
    {
        const __m256i t = _mm256_maddubs_epi16(_mm256_shuffle_epi8(top, pair_bytes_), wx);
        const __m256i b = _mm256_maddubs_epi16(_mm256_shuffle_epi8(bottom, pair_bytes_), wx);
        const __m256i d = _mm256_sub_epi16(b, t);
        const __m256i q = _mm256_mulhi_epi16(_mm256_add_epi16(d, d), fy_scaled);
        return _mm256_srai_epi16(_mm256_add_epi16(_mm256_add_epi16(t, q), sixteen_), 5);
    }

    const PlaneSpan &src_;
    bool replicate_;
    const std::uint8_t *border_;
    const long long *base_;
    __m256i w2_, h2_, m31_, k32_, pair_bytes_, one64_, pixels_a_, pixels_b_, sixteen_;
    __m128i stride_;
};

// Eight output pixels at a time (Cv4PixelsAvx2). Positions: m0 x 1024 and m3 x 1024 rounded
// once per call into a table (as OpenCV's adelta, bdelta; the same double operations, so the
// same roundings as the scalar code).
__attribute__((target("avx2"))) void warpRowsCv4Avx2(const PlaneSpan &src, std::uint8_t *dst, int dst_stride,
                                                     int dst_width, int row_begin, int row_end,
                                                     const double plane_m[6], bool replicate,
                                                     const std::uint8_t border[4])
{
    if (src.width < 2 || src.height < 2) {
        warpRowsCv4Scalar(src, dst, dst_stride, dst_width, row_begin, row_end, plane_m, replicate, border);
        return;
    }
    const CvStripe s = cvStripe(plane_m, row_begin);
    const double *m = s.m;
    // The per-column deltas of a block of columns, on the stack (no allocation): frames up
    // to kColumns wide in one block, wider ones in blocks of columns, each down all rows.
    constexpr int kColumns = 2048;
    alignas(32) int adelta[kColumns], bdelta[kColumns];
    const __m256d m0 = _mm256_set1_pd(m[0]), m3 = _mm256_set1_pd(m[3]), scale = _mm256_set1_pd(1024.0);
    const Cv4PixelsAvx2 pixels(src, replicate, border);
    for (int xb = 0; xb < dst_width; xb += kColumns) {
        const int xe = std::min(dst_width, xb + kColumns);
        // m0 x 1024 and m3 x 1024 rounded half to even (MXCSR's default mode, as cvRound), as
        // OpenCV's adelta and bdelta: the same double operations as the scalar code.
        for (int x = xb; x < xe; x += 4) {
            const __m256d xs = _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(x), _mm_setr_epi32(0, 1, 2, 3)));
            _mm_store_si128(reinterpret_cast<__m128i *>(adelta + (x - xb)),
                            _mm256_cvtpd_epi32(_mm256_mul_pd(_mm256_mul_pd(m0, xs), scale)));
            _mm_store_si128(reinterpret_cast<__m128i *>(bdelta + (x - xb)),
                            _mm256_cvtpd_epi32(_mm256_mul_pd(_mm256_mul_pd(m3, xs), scale)));
        }
        for (int y = row_begin; y < row_end; ++y) {
            const int yy = y - row_begin;
            const int X0 = cvRoundInt((m[1] * yy + m[2]) * 1024) + 16, Y0 = cvRoundInt((m[4] * yy + m[5]) * 1024) + 16;
            const __m256i X0v = _mm256_set1_epi32(X0), Y0v = _mm256_set1_epi32(Y0);
            std::uint8_t *out = dst + std::size_t(y) * dst_stride;
            int x = xb;
            for (; x + 8 <= xe; x += 8) {
                const __m256i X = _mm256_srai_epi32(
                    _mm256_add_epi32(X0v, _mm256_load_si256(reinterpret_cast<const __m256i *>(adelta + (x - xb)))), 5);
                const __m256i Y = _mm256_srai_epi32(
                    _mm256_add_epi32(Y0v, _mm256_load_si256(reinterpret_cast<const __m256i *>(bdelta + (x - xb)))), 5);
                pixels(X, Y, out + 4 * x);
            }
            for (; x < xe; ++x)
                samplePixelCv4(src, (X0 + adelta[x - xb]) >> 5, (Y0 + bdelta[x - xb]) >> 5, replicate, border,
                               out + 4 * x);
        }
    }
}

#endif // UAVSTAB_HAVE_X86

} // namespace

void warpPlaneBilinear16(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                         int row_end, const double m[6], bool replicate, std::uint16_t border, bool swap)
{
    const auto matrixOf = [m](int) { return m; };
    if (swap)
        warpRows16<true>(src, dst, dst_stride, dst_width, row_begin, row_end, matrixOf, replicate, border);
    else
        warpRows16<false>(src, dst, dst_stride, dst_width, row_begin, row_end, matrixOf, replicate, border);
}

void warpPlaneBilinear16Rows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                             int row_end, const std::array<double, 6> *row_m, bool replicate, std::uint16_t border,
                             bool swap)
{
    const auto matrixOf = [row_m, row_begin](int y) { return row_m[y - row_begin].data(); };
    if (swap)
        warpRows16<true>(src, dst, dst_stride, dst_width, row_begin, row_end, matrixOf, replicate, border);
    else
        warpRows16<false>(src, dst, dst_stride, dst_width, row_begin, row_end, matrixOf, replicate, border);
}

namespace {

// One mesh row's positions, column by column (the doubles WarpMesh::at gives).
class MeshRow {
public:
    explicit MeshRow(const WarpMesh &mesh)
        : mesh_(mesh), x_(std::size_t(mesh.columns)), y_(std::size_t(mesh.columns))
    {
    }
    void begin(int y) { mesh_.rowAt(y, x_.data(), y_.data()); }
    Point2 at(int x) const { return mesh_.alongRow(x_.data(), y_.data(), x); }
    const double *x() const { return x_.data(); }
    const double *y() const { return y_.data(); }

private:
    const WarpMesh &mesh_;
    std::vector<double> x_, y_;
};

bool meshFits(const WarpMesh &mesh, int dst_width, int row_end)
{
    return mesh.cell % kChunk == 0 && mesh.covers(std::max(dst_width, 1), std::max(row_end, 1));
}

template <int Channels>
inline void sampleMeshPixelCvAt(const PlaneSpan &src, int X, int Y, bool replicate, const std::uint8_t *border,
                                std::uint8_t *out);

// One 3- or 4-byte pixel at a mesh position s, rounded to 1/32 px as OpenCV's warpAffine
// rounds its positions ((round(s * 1024) + 16) >> 5), weighted as samplePixelCv4.
template <int Channels>
inline void sampleMeshPixelCv(const PlaneSpan &src, Point2 s, bool replicate, const std::uint8_t *border,
                              std::uint8_t *out)
{
    if (std::isnan(s.x) || std::isnan(s.y)) {
        std::copy(border, border + Channels, out);
        return;
    }
    // Far outside is as good as just outside (keeps the fixed point in range).
    const int X = (cvRoundInt(std::clamp(s.x, -30000.0, 30000.0) * 1024) + 16) >> 5;
    const int Y = (cvRoundInt(std::clamp(s.y, -30000.0, 30000.0) * 1024) + 16) >> 5;
    sampleMeshPixelCvAt<Channels>(src, X, Y, replicate, border, out);
}

// The same at the fixed-point position (X, Y) (1/32 px).
template <int Channels>
inline void sampleMeshPixelCvAt(const PlaneSpan &src, int X, int Y, bool replicate, const std::uint8_t *border,
                                std::uint8_t *out)
{
    if (Channels == 4) {
        samplePixelCv4(src, X, Y, replicate, border, out);
        return;
    }
    const int sx = X >> 5, sy = Y >> 5, fx = X & 31, fy = Y & 31;
    const int w[4] = {(32 - fx) * (32 - fy), fx * (32 - fy), (32 - fx) * fy, fx * fy};
    const std::uint8_t *tap[4];
    for (int k = 0; k < 4; ++k) {
        int tx = sx + (k & 1), ty = sy + (k >> 1);
        if (tx >= 0 && ty >= 0 && tx < src.width && ty < src.height) {
            tap[k] = src.data + std::size_t(ty) * src.stride + std::size_t(tx) * Channels;
        } else if (replicate) {
            tx = std::clamp(tx, 0, src.width - 1);
            ty = std::clamp(ty, 0, src.height - 1);
            tap[k] = src.data + std::size_t(ty) * src.stride + std::size_t(tx) * Channels;
        } else {
            tap[k] = border;
        }
    }
    for (int c = 0; c < Channels; ++c) {
        const int v = tap[0][c] * w[0] + tap[1][c] * w[1] + tap[2][c] * w[2] + tap[3][c] * w[3];
        out[c] = std::uint8_t(std::min(255, (v + 512) >> 10));
    }
}

// The 3- and 4-byte mesh warps' positions, in fixed point: each node of a row (rowAt's
// doubles) rounded to 2^-24 px (kMeshNodeBits), and inside a cell whose four nodes lie within
// +-29000 px the position at k px right of its left node N_i is N_i + k D_i, D_i =
// floor((N_{i+1} - N_i) / cell); its 1/32 px (OpenCV's (round(s x 1024) + 16) >> 5, a tie at
// 1/2048 rounded up) is (N_i + k D_i + kMeshRound) >> kMeshShift. That lies within 2^-24 px
// x (1 + k) of alongRow's double, so a byte differs from the double positions' only where one
// lies within ~1e-6 px of a 1/1024 step. Other cells (a node NaN or far out): alongRow's
// doubles, clamped and rounded per pixel (sampleMeshPixelCv).
constexpr int kMeshNodeBits = 24;
constexpr int kMeshShift = kMeshNodeBits - 5;
constexpr long long kMeshRound = (1LL << (kMeshNodeBits - 11)) + (1LL << (kMeshShift - 1));

inline bool meshNodePlain(double v) { return std::abs(v) < 29000.0; }  // false for NaN

// A node's position in 2^-24 px, rounded half to even (as the AVX2 kernel's magic-number
// conversion); 0 where it is not plain (not used there).
inline long long meshNodeFixed(double v)
{
    return meshNodePlain(v) ? std::llrint(v * double(1 << kMeshNodeBits)) : 0;
}

// floor(d / cell), a shift when the cell is a power of two.
inline long long meshFloorDiv(long long d, int cell, int cell_shift)
{
    if (cell_shift >= 0)
        return d >> cell_shift;
    long long q = d / cell;
    if (d % cell != 0 && d < 0)
        --q;
    return q;
}

inline int meshCellShift(int cell)
{
    for (int s = 0; s < 30; ++s)
        if (cell == 1 << s)
            return s;
    return -1;
}

// The fixed-point nodes of one output row (after MeshRow::begin), and each cell's steps.
class MeshRowFixed {
public:
    explicit MeshRowFixed(const WarpMesh &mesh)
        : mesh_(mesh), row_(mesh), cell_shift_(meshCellShift(mesh.cell)), nx_(std::size_t(mesh.columns)),
          ny_(std::size_t(mesh.columns))
    {
    }
    void begin(int y)
    {
        row_.begin(y);
        for (int i = 0; i < mesh_.columns; ++i) {
            nx_[std::size_t(i)] = meshNodeFixed(row_.x()[i]);
            ny_[std::size_t(i)] = meshNodeFixed(row_.y()[i]);
        }
    }
#ifdef UAVSTAB_HAVE_X86
    // begin's nodes four at a time: v x 2^24 + 1.5 x 2^52 leaves round(v x 2^24) (|v| <
    // 29000: below 2^39) in the low mantissa bits, rounded half to even as llrint.
    __attribute__((target("avx2"))) void beginAvx2(int y)
    {
        row_.begin(y);
        const __m256d scale = _mm256_set1_pd(double(1 << kMeshNodeBits)), magic = _mm256_set1_pd(6755399441055744.0);
        const __m256d limit = _mm256_set1_pd(29000.0), abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
        const __m256i magic_bits = _mm256_castpd_si256(magic);
        int i = 0;
        for (; i + 4 <= mesh_.columns; i += 4)
            for (int axis = 0; axis < 2; ++axis) {
                const double *v = axis ? row_.y() : row_.x();
                long long *n = (axis ? ny_ : nx_).data();
                const __m256d d = _mm256_loadu_pd(v + i);
                const __m256d plain = _mm256_cmp_pd(_mm256_and_pd(d, abs_mask), limit, _CMP_LT_OQ);
                const __m256i bits =
                    _mm256_sub_epi64(_mm256_castpd_si256(_mm256_add_pd(_mm256_mul_pd(d, scale), magic)), magic_bits);
                _mm256_storeu_si256(reinterpret_cast<__m256i *>(n + i),
                                    _mm256_and_si256(bits, _mm256_castpd_si256(plain)));
            }
        for (; i < mesh_.columns; ++i) {
            nx_[std::size_t(i)] = meshNodeFixed(row_.x()[i]);
            ny_[std::size_t(i)] = meshNodeFixed(row_.y()[i]);
        }
        planCellsAvx2();
    }

    // The AVX2 kernel's 32-bit lanes for cell i (after beginAvx2): when fast(i), the position
    // k px into the cell is A + ((a + k D) >> kMeshShift), A 2^kMeshShift + a = N_i +
    // kMeshRound, on each axis, with no 32-bit overflow for k < cell.
    bool fast(int i) const { return fast_[std::size_t(i)] != 0; }
    const int *cellA(int axis) const { return (axis ? ay_ : ax_).data(); }
    const int *cellLow(int axis) const { return (axis ? ly_ : lx_).data(); }
    const int *cellStep(int axis) const { return (axis ? dy_ : dx_).data(); }
#endif
    const MeshRow &row() const { return row_; }
    // Whether cell i's positions are fixed point (its four nodes plain).
    bool plain(int i) const
    {
        return meshNodePlain(row_.x()[i]) && meshNodePlain(row_.x()[i + 1]) && meshNodePlain(row_.y()[i]) &&
               meshNodePlain(row_.y()[i + 1]);
    }
    long long nx(int i) const { return nx_[std::size_t(i)]; }
    long long ny(int i) const { return ny_[std::size_t(i)]; }
    long long dx(int i) const { return meshFloorDiv(nx_[std::size_t(i) + 1] - nx_[std::size_t(i)], mesh_.cell, cell_shift_); }
    long long dy(int i) const { return meshFloorDiv(ny_[std::size_t(i) + 1] - ny_[std::size_t(i)], mesh_.cell, cell_shift_); }
    // The cell of column x (the last one extends past its right node) and x's place in it.
    int cellOf(int x, int &k) const
    {
        const int i = std::min(x / mesh_.cell, mesh_.columns - 2);
        k = x - i * mesh_.cell;
        return i;
    }

private:
#ifdef UAVSTAB_HAVE_X86
    // fast_, A, a and D of every cell, four cells at a time where the cell is a power of two
    // (a shift: floor((N_{i+1} - N_i) / cell)'s low 32 bits, which are D's when it is fast).
    __attribute__((target("avx2"))) void planCellsAvx2()
    {
        const int cells = mesh_.columns - 1;
        if (ax_.empty()) {
            for (auto *v : {&ax_, &lx_, &dx_, &ay_, &ly_, &dy_})
                v->resize(std::size_t(cells) + 4);
            fast_.resize(std::size_t(cells) + 4);
        }
        // |N_{i+1} - N_i| <= limit: |D| <= limit / cell, and |a + k D| < 2^kMeshShift + (cell - 1) |D| < 2^31.
        const long long limit = ((1LL << 31) - (1LL << kMeshShift)) / mesh_.cell - 1;
        const long long span_limit = limit * mesh_.cell;
        int i = 0;
        if (cell_shift_ >= 0) {
            const __m256i round = _mm256_set1_epi64x(kMeshRound), low = _mm256_set1_epi64x((1LL << kMeshShift) - 1);
            const __m256i hi = _mm256_set1_epi64x(span_limit), lo = _mm256_set1_epi64x(-span_limit);
            const __m256i pick = _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0);
            const __m128i shift = _mm_cvtsi32_si128(cell_shift_), node_shift = _mm_cvtsi32_si128(kMeshShift);
            const auto low32 = [&](__m256i v) __attribute__((target("avx2"), always_inline)) {
                return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(v, pick));
            };
            for (; i + 4 <= cells; i += 4) {
                __m256i ok = _mm256_set1_epi64x(-1);
                for (int axis = 0; axis < 2; ++axis) {
                    const long long *n = (axis ? ny_ : nx_).data() + i;
                    const double *v = (axis ? row_.y() : row_.x()) + i;
                    const __m256i n0 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(n));
                    const __m256i n1 = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(n + 1));
                    const __m256i diff = _mm256_sub_epi64(n1, n0);
                    const __m256i b = _mm256_add_epi64(n0, round);
                    // Logical shifts: their low 32 bits are the arithmetic shifts'.
                    _mm_storeu_si128(reinterpret_cast<__m128i *>((axis ? ay_ : ax_).data() + i),
                                     low32(_mm256_srl_epi64(b, node_shift)));
                    _mm_storeu_si128(reinterpret_cast<__m128i *>((axis ? ly_ : lx_).data() + i),
                                     low32(_mm256_and_si256(b, low)));
                    _mm_storeu_si128(reinterpret_cast<__m128i *>((axis ? dy_ : dx_).data() + i),
                                     low32(_mm256_srl_epi64(diff, shift)));
                    const __m256d limit_pd = _mm256_set1_pd(29000.0);
                    const __m256d abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
                    const __m256d p0 = _mm256_cmp_pd(_mm256_and_pd(_mm256_loadu_pd(v), abs_mask), limit_pd, _CMP_LT_OQ);
                    const __m256d p1 =
                        _mm256_cmp_pd(_mm256_and_pd(_mm256_loadu_pd(v + 1), abs_mask), limit_pd, _CMP_LT_OQ);
                    const __m256i out = _mm256_or_si256(_mm256_cmpgt_epi64(diff, hi), _mm256_cmpgt_epi64(lo, diff));
                    ok = _mm256_andnot_si256(out, _mm256_and_si256(ok, _mm256_castpd_si256(_mm256_and_pd(p0, p1))));
                }
                const int mask = _mm256_movemask_pd(_mm256_castsi256_pd(ok));
                for (int j = 0; j < 4; ++j)
                    fast_[std::size_t(i + j)] = std::uint8_t((mask >> j) & 1);
            }
        }
        for (; i < cells; ++i) {
            const long long d[2] = {dx(i), dy(i)}, n[2] = {nx(i), ny(i)};
            bool ok = plain(i);
            for (int axis = 0; axis < 2; ++axis) {
                const long long diff = (axis ? ny_ : nx_)[std::size_t(i) + 1] - (axis ? ny_ : nx_)[std::size_t(i)];
                ok = ok && std::abs(diff) <= span_limit;
                const long long b = n[axis] + kMeshRound;
                (axis ? ay_ : ax_)[std::size_t(i)] = int(b >> kMeshShift);
                (axis ? ly_ : lx_)[std::size_t(i)] = int(b & ((1LL << kMeshShift) - 1));
                (axis ? dy_ : dx_)[std::size_t(i)] = ok ? int(d[axis]) : 0;
            }
            fast_[std::size_t(i)] = ok;
        }
    }
    std::vector<int> ax_, lx_, dx_, ay_, ly_, dy_;
    std::vector<std::uint8_t> fast_;
#endif
    const WarpMesh &mesh_;
    MeshRow row_;
    int cell_shift_;
    std::vector<long long> nx_, ny_;
};

// One 3- or 4-byte pixel of column x of the row `row` holds.
template <int Channels>
inline void sampleMeshPixelFixed(const PlaneSpan &src, const MeshRowFixed &row, int x, bool replicate,
                                 const std::uint8_t *border, std::uint8_t *out)
{
    int k;
    const int i = row.cellOf(x, k);
    if (!row.plain(i)) {
        sampleMeshPixelCv<Channels>(src, row.row().at(x), replicate, border, out);
        return;
    }
    const int X = int((row.nx(i) + row.dx(i) * k + kMeshRound) >> kMeshShift);
    const int Y = int((row.ny(i) + row.dy(i) * k + kMeshRound) >> kMeshShift);
    sampleMeshPixelCvAt<Channels>(src, X, Y, replicate, border, out);
}

template <int Channels>
void warpMeshRowsCv(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                    int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4])
{
    MeshRowFixed row(mesh);
    for (int y = row_begin; y < row_end; ++y) {
        row.begin(y);
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        for (int x = 0; x < dst_width; ++x)
            sampleMeshPixelFixed<Channels>(src, row, x, replicate, border, out + Channels * x);
    }
}

#ifdef UAVSTAB_HAVE_X86

// warpMeshRowsCv<4> eight pixels at a time (Cv4PixelsAvx2): eight columns from a multiple of
// 8 lie in one cell (a multiple of 16 wide). A fixed-point cell: its 32-bit lanes hold
// N_i + kMeshRound split as A 2^kMeshShift + a, and a + k D_i (when that cannot overflow),
// so that X = A + ((a + k D_i) >> kMeshShift), the same integer; each group of eight adds
// 8 D_i. Other cells: alongRow's expressions in double vectors (the same doubles; cvtpd
// rounds half to even as cvRound); groups with a NaN position and the columns past the
// last group: per pixel.
__attribute__((target("avx2"))) void warpMeshRowsCv4Avx2(const PlaneSpan &src, std::uint8_t *dst, int dst_stride,
                                                         int dst_width, int row_begin, int row_end,
                                                         const WarpMesh &mesh, bool replicate,
                                                         const std::uint8_t border[4])
{
    if (src.width < 2 || src.height < 2) {
        warpMeshRowsCv<4>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
        return;
    }
    const Cv4PixelsAvx2 pixels(src, replicate, border);
    MeshRowFixed fixed_row(mesh);
    const MeshRow &row = fixed_row.row();
    const __m256d k1024 = _mm256_set1_pd(1024.0);
    const __m256d low = _mm256_set1_pd(-30000.0), high = _mm256_set1_pd(30000.0);
    const __m128i sixteen = _mm_set1_epi32(16);
    const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    // Clamped, x 1024, rounded, + 16: (round(s * 1024) + 16) of four pixels.
    const auto fixed = [&](__m256d v) __attribute__((target("avx2"))) {
        return _mm_add_epi32(_mm256_cvtpd_epi32(_mm256_mul_pd(_mm256_min_pd(_mm256_max_pd(v, low), high), k1024)),
                             sixteen);
    };
    // (x - x_cell) / cell for every column of a cell: the same doubles as dividing there.
    std::vector<double> fractions(std::size_t(mesh.cell));
    for (int k = 0; k < mesh.cell; ++k)
        fractions[std::size_t(k)] = double(k) / mesh.cell;
    for (int y = row_begin; y < row_end; ++y) {
        fixed_row.beginAvx2(y);
        const int *cell_ax = fixed_row.cellA(0), *cell_lx = fixed_row.cellLow(0), *cell_dx = fixed_row.cellStep(0);
        const int *cell_ay = fixed_row.cellA(1), *cell_ly = fixed_row.cellLow(1), *cell_dy = fixed_row.cellStep(1);
        const double *row_x = row.x(), *row_y = row.y();
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        int x = 0;
        // Cell by cell (a cell holds whole groups of eight: its width is a multiple of 16).
        for (int i = 0; x + 8 <= dst_width; ++i) {
            const int cell_end = std::min(dst_width, (i + 1) * mesh.cell);
            if (fixed_row.fast(i)) {
                const __m256i dx = _mm256_set1_epi32(cell_dx[i]), dy = _mm256_set1_epi32(cell_dy[i]);
                const __m256i ax = _mm256_set1_epi32(cell_ax[i]), ay = _mm256_set1_epi32(cell_ay[i]);
                __m256i fx = _mm256_add_epi32(_mm256_set1_epi32(cell_lx[i]), _mm256_mullo_epi32(dx, lanes));
                __m256i fy = _mm256_add_epi32(_mm256_set1_epi32(cell_ly[i]), _mm256_mullo_epi32(dy, lanes));
                const __m256i step_x = _mm256_slli_epi32(dx, 3), step_y = _mm256_slli_epi32(dy, 3);
                for (; x + 8 <= cell_end; x += 8) {
                    pixels(_mm256_add_epi32(ax, _mm256_srai_epi32(fx, kMeshShift)),
                           _mm256_add_epi32(ay, _mm256_srai_epi32(fy, kMeshShift)), out + 4 * x);
                    fx = _mm256_add_epi32(fx, step_x);
                    fy = _mm256_add_epi32(fy, step_y);
                }
                continue;
            }
            if (fixed_row.plain(i)) {
                const long long dx = fixed_row.dx(i), dy = fixed_row.dy(i);
                for (; x + 8 <= cell_end; x += 8) {
                    alignas(32) int xv[8], yv[8];
                    const int k0 = x - i * mesh.cell;
                    for (int j = 0; j < 8; ++j) {
                        xv[j] = int((fixed_row.nx(i) + dx * (k0 + j) + kMeshRound) >> kMeshShift);
                        yv[j] = int((fixed_row.ny(i) + dy * (k0 + j) + kMeshRound) >> kMeshShift);
                    }
                    pixels(_mm256_load_si256(reinterpret_cast<const __m256i *>(xv)),
                           _mm256_load_si256(reinterpret_cast<const __m256i *>(yv)), out + 4 * x);
                }
                continue;
            }
            const double lx = row_x[i], ly = row_y[i], rx = row_x[i + 1], ry = row_y[i + 1];
            const __m256d left_x = _mm256_set1_pd(lx), span_x = _mm256_set1_pd(rx - lx);
            const __m256d left_y = _mm256_set1_pd(ly), span_y = _mm256_set1_pd(ry - ly);
            for (; x + 8 <= cell_end; x += 8) {
                const double *f = fractions.data() + (x - i * mesh.cell);
                const __m256d s0 = _mm256_loadu_pd(f), s1 = _mm256_loadu_pd(f + 4);
                const __m256d sx0 = _mm256_add_pd(left_x, _mm256_mul_pd(span_x, s0));
                const __m256d sx1 = _mm256_add_pd(left_x, _mm256_mul_pd(span_x, s1));
                const __m256d sy0 = _mm256_add_pd(left_y, _mm256_mul_pd(span_y, s0));
                const __m256d sy1 = _mm256_add_pd(left_y, _mm256_mul_pd(span_y, s1));
                const __m256d nan = _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(sx0, sx0, _CMP_UNORD_Q),
                                                              _mm256_cmp_pd(sx1, sx1, _CMP_UNORD_Q)),
                                                 _mm256_or_pd(_mm256_cmp_pd(sy0, sy0, _CMP_UNORD_Q),
                                                              _mm256_cmp_pd(sy1, sy1, _CMP_UNORD_Q)));
                if (_mm256_movemask_pd(nan) != 0) {
                    for (int j = 0; j < 8; ++j)
                        sampleMeshPixelCv<4>(src, row.at(x + j), replicate, border, out + 4 * (x + j));
                    continue;
                }
                const __m256i X = _mm256_srai_epi32(_mm256_set_m128i(fixed(sx1), fixed(sx0)), 5);
                const __m256i Y = _mm256_srai_epi32(_mm256_set_m128i(fixed(sy1), fixed(sy0)), 5);
                pixels(X, Y, out + 4 * x);
            }
        }
        if (x < dst_width)
            cleanUpperHalves();
        for (; x < dst_width; ++x)
            sampleMeshPixelFixed<4>(src, fixed_row, x, replicate, border, out + 4 * x);
    }
    cleanUpperHalves();
}

#endif // UAVSTAB_HAVE_X86

template <bool Swap>
void warpMeshRows16(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                    int row_end, const WarpMesh &mesh, bool replicate, std::uint16_t border)
{
    MeshRow row(mesh);
    for (int y = row_begin; y < row_end; ++y) {
        row.begin(y);
        std::uint8_t *out = dst + std::size_t(y) * dst_stride;
        for (int x = 0; x < dst_width; ++x) {
            const Point2 s = row.at(x);
            samplePixel16<Swap>(src, replicate, border, out + 2 * x, s.x, s.y);
        }
    }
}

} // namespace

bool warpPlaneBilinear16Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                             int row_end, const WarpMesh &mesh, bool replicate, std::uint16_t border, bool swap)
{
    if (!mesh.covers(std::max(dst_width, 1), std::max(row_end, 1)) || src.width < 1 || src.height < 1)
        return false;
    if (swap)
        warpMeshRows16<true>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
    else
        warpMeshRows16<false>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
    return true;
}

bool warpPlaneBilinear4Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4])
{
    return warpPlaneBilinear4Mesh(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border,
                                  warpKernel() == WarpKernel::Avx2 ? WarpKernel::Avx2 : WarpKernel::Scalar);
}

bool warpPlaneBilinear4Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4],
                            WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel) || !meshFits(mesh, dst_width, row_end) || src.width < 1 || src.height < 1)
        return false;
    switch (kernel) {
    case WarpKernel::Scalar:
        warpMeshRowsCv<4>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
        return true;
    case WarpKernel::Avx2:
#ifdef UAVSTAB_HAVE_X86
        // Its gathers take 32-bit byte offsets into the plane.
        if (std::size_t(src.stride) * std::size_t(src.height) >= std::size_t(1) << 31)
            warpMeshRowsCv<4>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
        else
            warpMeshRowsCv4Avx2(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
        return true;
#else
        return false;
#endif
    case WarpKernel::Simd128:
        return false;
    }
    return false;
}

bool warpPlaneBilinear3Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4])
{
    if (!mesh.covers(std::max(dst_width, 1), std::max(row_end, 1)) || src.width < 1 || src.height < 1)
        return false;
    warpMeshRowsCv<3>(src, dst, dst_stride, dst_width, row_begin, row_end, mesh, replicate, border);
    return true;
}

bool warpPlaneBilinearMesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const WarpMesh &mesh, bool replicate,
                           const std::uint8_t border[4])
{
    return warpPlaneBilinearMesh(src, dst, dst_stride, dst_width, row_begin, row_end, channels, mesh, replicate,
                                 border, warpKernel());
}

bool warpPlaneBilinearMesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const WarpMesh &mesh, bool replicate,
                           const std::uint8_t border[4], WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel) || !(channels == 1 || channels == 2) || !meshFits(mesh, dst_width, row_end) ||
        src.width < 1 || src.height < 1)
        return false;
    if (row_end <= row_begin)
        return true;
    MatrixPerChunk chunks(mesh, channels, src.width >= kChunk + 2, dst_width / kChunk);
    switch (kernel) {
    case WarpKernel::Avx2:
#ifdef UAVSTAB_HAVE_X86
    {
        const MeshWarpPlane plane[1] = {{src, dst, dst_stride, border}};
        if (channels == 1)
            warpMeshRowsAvx2<1, 1>(plane, dst_width, row_begin, row_end, chunks, replicate);
        else
            warpMeshRowsAvx2<2, 1>(plane, dst_width, row_begin, row_end, chunks, replicate);
        return true;
    }
#else
        return false;
#endif
    case WarpKernel::Simd128:
#ifdef UAVSTAB_HAVE_SIMD128
        if (channels == 1)
            warpMeshRows128<1>(src, dst, dst_stride, dst_width, row_begin, row_end, chunks, replicate, border);
        else
            warpMeshRows128<2>(src, dst, dst_stride, dst_width, row_begin, row_end, chunks, replicate, border);
        return true;
#else
        return false;
#endif
    case WarpKernel::Scalar:
        warpMeshRowsScalar(src, dst, dst_stride, dst_width, row_begin, row_end, channels, chunks, replicate, border);
        return true;
    }
    return false;
}

bool warpPlanePairBilinearMesh(const MeshWarpPlane &a, const MeshWarpPlane &b, int dst_width, int row_begin,
                               int row_end, const WarpMesh &mesh, bool replicate)
{
    return warpPlanePairBilinearMesh(a, b, dst_width, row_begin, row_end, mesh, replicate, warpKernel());
}

bool warpPlanePairBilinearMesh(const MeshWarpPlane &a, const MeshWarpPlane &b, int dst_width, int row_begin,
                               int row_end, const WarpMesh &mesh, bool replicate, WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel) || !meshFits(mesh, dst_width, row_end) || a.src.width < 1 || a.src.height < 1 ||
        a.src.width != b.src.width || a.src.height != b.src.height)
        return false;
#ifdef UAVSTAB_HAVE_X86
    if (kernel == WarpKernel::Avx2) {
        if (row_end > row_begin) {
            MatrixPerChunk chunks(mesh, 1, a.src.width >= kChunk + 2, dst_width / kChunk);
            const MeshWarpPlane planes[2] = {a, b};
            warpMeshRowsAvx2<1, 2>(planes, dst_width, row_begin, row_end, chunks, replicate);
        }
        return true;
    }
#endif
    // The other kernels plan per plane.
    return warpPlaneBilinearMesh(a.src, a.dst, a.dst_stride, dst_width, row_begin, row_end, 1, mesh, replicate,
                                 a.border, kernel) &&
           warpPlaneBilinearMesh(b.src, b.dst, b.dst_stride, dst_width, row_begin, row_end, 1, mesh, replicate,
                                 b.border, kernel);
}

bool warpKernelAvailable(WarpKernel kernel)
{
    switch (kernel) {
    case WarpKernel::Scalar:
        return true;
    case WarpKernel::Simd128:
#ifdef UAVSTAB_HAVE_SIMD128
        return cpuHasSimd128();
#else
        return false;
#endif
    case WarpKernel::Avx2:
#ifdef UAVSTAB_HAVE_X86
        return cpuHasAvx2();
#else
        return false;
#endif
    }
    return false;
}

const char *warpKernelName(WarpKernel kernel)
{
    switch (kernel) {
    case WarpKernel::Scalar:
        return "scalar";
    case WarpKernel::Simd128:
#ifdef UAVSTAB_HAVE_X86
        return "sse128";
#else
        return "neon128";
#endif
    case WarpKernel::Avx2:
        return "avx2";
    }
    return "?";
}

WarpKernel warpKernel()
{
    static const WarpKernel chosen = [] {
        WarpKernel best = WarpKernel::Scalar;
        for (WarpKernel k : {WarpKernel::Simd128, WarpKernel::Avx2})
            if (warpKernelAvailable(k))
                best = k;
        const char *env = std::getenv("UAVSTAB_WARP_KERNEL");
        if (env == nullptr || *env == '\0')
            return best;
        const std::string want = env;
        for (WarpKernel k : {WarpKernel::Scalar, WarpKernel::Simd128, WarpKernel::Avx2})
            if (want == warpKernelName(k) || (k == WarpKernel::Simd128 && want == "simd128")) {
                if (warpKernelAvailable(k))
                    return k;
                break;
            }
        std::fprintf(stderr, "uavstab: UAVSTAB_WARP_KERNEL=%s is not available here (scalar, simd128, avx2): using %s\n",
                     env, warpKernelName(best));
        return best;
    }();
    return chosen;
}

bool warpPlaneBilinear(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                       int row_end, int channels, const double m[6], bool replicate, const std::uint8_t border[4])
{
    return warpPlaneBilinear(src, dst, dst_stride, dst_width, row_begin, row_end, channels, m, replicate, border,
                             warpKernel());
}

namespace {

// Runs the kernel over rows [row_begin, row_end), every row's matrix already checked.
template <class Matrices>
bool runKernel(WarpKernel kernel, const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width,
               int row_begin, int row_end, int channels, Matrices &matrices, bool replicate,
               const std::uint8_t border[4])
{
    switch (kernel) {
    case WarpKernel::Avx2:
#ifdef UAVSTAB_HAVE_X86
        if (channels == 1)
            warpRowsAvx2<1>(src, dst, dst_stride, dst_width, row_begin, row_end, matrices, replicate, border);
        else
            warpRowsAvx2<2>(src, dst, dst_stride, dst_width, row_begin, row_end, matrices, replicate, border);
        return true;
#else
        return false;
#endif
    case WarpKernel::Simd128:
#ifdef UAVSTAB_HAVE_SIMD128
        if (channels == 1)
            warpRows128<1>(src, dst, dst_stride, dst_width, row_begin, row_end, matrices, replicate, border);
        else
            warpRows128<2>(src, dst, dst_stride, dst_width, row_begin, row_end, matrices, replicate, border);
        return true;
#else
        return false;
#endif
    case WarpKernel::Scalar:
        warpRowsScalar(src, dst, dst_stride, dst_width, row_begin, row_end, channels, matrices, replicate, border);
        return true;
    }
    return false;
}

} // namespace

bool warpPlaneBilinear4(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                        int row_end, const double m[6], bool replicate, const std::uint8_t border[4], WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel) || !cv4Handles(m, dst_width, row_begin, row_end) || src.width < 1 ||
        src.height < 1)
        return false;
    switch (kernel) {
    case WarpKernel::Scalar:
        warpRowsCv4Scalar(src, dst, dst_stride, dst_width, row_begin, row_end, m, replicate, border);
        return true;
    case WarpKernel::Avx2:
#ifdef UAVSTAB_HAVE_X86
        // Its gathers take 32-bit byte offsets into the plane.
        if (std::size_t(src.stride) * std::size_t(src.height) >= std::size_t(1) << 31)
            return false;
        warpRowsCv4Avx2(src, dst, dst_stride, dst_width, row_begin, row_end, m, replicate, border);
        return true;
#else
        return false;
#endif
    case WarpKernel::Simd128:
        return false;
    }
    return false;
}

bool warpPlaneBilinear4(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                        int row_end, const double m[6], bool replicate, const std::uint8_t border[4])
{
    // Only the AVX2 kernel: elsewhere OpenCV's own warp is faster than the scalar one.
    return warpKernel() == WarpKernel::Avx2 &&
           warpPlaneBilinear4(src, dst, dst_stride, dst_width, row_begin, row_end, m, replicate, border,
                              WarpKernel::Avx2);
}

bool warpPlaneBilinearHandles(const PlaneSpan &src, int channels, const double m[6])
{
    // Four-channel pixels fill a vector with only 4 pixels; measured no faster than
    // OpenCV there, so only planar luma/chroma (1) and interleaved chroma (2) come here
    // (4-channel planes keep OpenCV's output, now from warpPlaneBilinear4).
    // The window trick needs the source to advance forwards by at most 1.25 px per output
    // pixel and to cross at most one source row per chunk.
    return (channels == 1 || channels == 2) && m[0] > 0.0 && m[0] <= 1.25 &&
           std::abs(m[3]) * (kChunk - 1) <= 0.9 && src.width >= kChunk + 2;
}

bool warpPlaneBilinear(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                       int row_end, int channels, const double m[6], bool replicate, const std::uint8_t border[4],
                       WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel) || !warpPlaneBilinearHandles(src, channels, m))
        return false;
    OneMatrix matrices(m, channels);
    return runKernel(kernel, src, dst, dst_stride, dst_width, row_begin, row_end, channels, matrices, replicate,
                     border);
}

bool warpPlaneBilinearRows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const std::array<double, 6> *row_m, bool replicate,
                           const std::uint8_t border[4])
{
    return warpPlaneBilinearRows(src, dst, dst_stride, dst_width, row_begin, row_end, channels, row_m, replicate,
                                 border, warpKernel());
}

bool warpPlaneBilinearRows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const std::array<double, 6> *row_m, bool replicate,
                           const std::uint8_t border[4], WarpKernel kernel)
{
    if (!warpKernelAvailable(kernel))
        return false;
    for (int y = row_begin; y < row_end; ++y)
        if (!warpPlaneBilinearHandles(src, channels, row_m[y - row_begin].data()))
            return false;
    if (row_end <= row_begin)
        return true;
    MatrixPerRow matrices(row_m, row_begin, channels);
    return runKernel(kernel, src, dst, dst_stride, dst_width, row_begin, row_end, channels, matrices, replicate,
                     border);
}

} // namespace uavstab
