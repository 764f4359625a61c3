// A fast bilinear resampler for one 8-bit plane under an affine map that is
// close to a similarity (the stabilizer's case: rotation of a few degrees, scale near 1).
//
// OpenCV's warpAffine spends most of its time computing and gathering source
// coordinates pixel by pixel. Here, along an output row the source advances by a nearly
// constant step, so 8 or 16 output bytes read from one 16-byte window per source row: a
// byte shuffle replaces the gather. Positions are quantised to 1/64 pixel (OpenCV: 1/32).
// Pixels whose taps leave the frame or the window take the per-pixel path.
//
// Three kernels write the same bytes (the tests compare them): AVX2 (x86, chosen at run
// time), a 128-bit one written once with OpenCV's universal intrinsics (NEON on ARM;
// SSE2 + SSSE3 on x86 without AVX2) and a scalar reference that spells out their integer
// arithmetic (used where neither exists). So a given input warps to the same output on
// every machine.
//
// Each kernel also takes a matrix per output row (rolling-shutter correction) in the same
// pass: a row warped with its own matrix gets exactly the bytes the single-matrix warp
// writes there.
#pragma once

#include <array>
#include <cstdint>

#include "render/warp_mesh.hpp"

namespace uavstab {

struct PlaneSpan {
    const std::uint8_t *data;
    int stride;
    int width;   // pixels
    int height;
};

enum class WarpKernel { Scalar, Simd128, Avx2 };

// "scalar", "sse128" / "neon128" (Simd128 on x86 / ARM), "avx2".
const char *warpKernelName(WarpKernel kernel);
// Whether this build and this CPU have the kernel.
bool warpKernelAvailable(WarpKernel kernel);
// The kernel warpPlaneBilinear uses: the fastest available (AVX2 > 128-bit > scalar), or
// the one named by the environment variable UAVSTAB_WARP_KERNEL (scalar, simd128 or its
// name above, avx2) when this CPU has it. Read once.
WarpKernel warpKernel();

// dst(x, y) = src(m * (x, y, 1)) for dst rows [row_begin, row_end), `channels` interleaved
// bytes per pixel (1 or 2: luma and chroma planes). Returns false, having written nothing, when this transform
// is not handled (the caller then uses a general warp).
bool warpPlaneBilinear(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                       int row_end, int channels, const double m[6], bool replicate, const std::uint8_t border[4]);
// The same with a given kernel (tests); false also when the kernel is not available.
bool warpPlaneBilinear(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                       int row_end, int channels, const double m[6], bool replicate, const std::uint8_t border[4],
                       WarpKernel kernel);

// Whether warpPlaneBilinear handles this transform (given an available kernel).
bool warpPlaneBilinearHandles(const PlaneSpan &src, int channels, const double m[6]);

// A transform per destination row, in one pass (rolling-shutter correction): dst row y is
// warped by row_m[y - row_begin] and gets the bytes warpPlaneBilinear writes there with
// that matrix. Returns false, having written nothing, when any row's transform is not
// handled (warpPlaneBilinearHandles).
bool warpPlaneBilinearRows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const std::array<double, 6> *row_m, bool replicate,
                           const std::uint8_t border[4]);
bool warpPlaneBilinearRows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const std::array<double, 6> *row_m, bool replicate,
                           const std::uint8_t border[4], WarpKernel kernel);

// 4 interleaved bytes per pixel (BGRx, RGBA...): writes the bytes cv::warpAffine(INTER_LINEAR |
// WARP_INVERSE_MAP, BORDER_CONSTANT with `border` or BORDER_REPLICATE) writes into dst rows
// [row_begin, row_end) when given the plane matrix m shifted to row_begin and those rows
// (as FrameWarper hands it a stripe): OpenCV 4's fixed-point bilinear, 1/32 px, in one pass.
// False, having written nothing, when the kernel is not available here or the transform
// reads too far out (|source| >= 30000 px). Without a kernel: the AVX2 one, or false when
// this CPU has none (OpenCV's own warp is then the faster); Scalar spells the arithmetic
// out (tests).
bool warpPlaneBilinear4(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                        int row_end, const double m[6], bool replicate, const std::uint8_t border[4]);
bool warpPlaneBilinear4(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                        int row_end, const double m[6], bool replicate, const std::uint8_t border[4],
                        WarpKernel kernel);

// The same for one plane of 16-bit samples (one channel), at full depth: taps weighted in
// double precision and the result rounded to the nearest integer, so that an integer
// position reproduces its sample exactly and nothing is clipped or rescaled (a bilinear
// value lies between its taps). Samples are read and written byte-swapped when `swap`
// (the plane's byte order is not the host's). Taps outside the frame read `border` or,
// with `replicate`, the nearest edge sample. Handles every transform.
void warpPlaneBilinear16(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                         int row_end, const double m[6], bool replicate, std::uint16_t border, bool swap);
// The same with a transform per destination row, row_m[y - row_begin] for row y.
void warpPlaneBilinear16Rows(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                             int row_end, const std::array<double, 6> *row_m, bool replicate, std::uint16_t border,
                             bool swap);

// ---- Mesh warps (lens correction): a source position per node of a coarse output grid,
// bilinear between nodes (WarpMesh). dst rows [row_begin, row_end) of a plane; the mesh in
// that plane's pixels, covering dst_width x row_end (WarpMesh::covers) with a cell that is a
// multiple of 16. Every function returns false, having written nothing, when the mesh does
// not cover the rows or the source is empty.

// 1 or 2 interleaved bytes per pixel, in one pass, on every kernel (the same bytes on each).
// Along an output row inside one cell the mesh is linear in x, so each 16-pixel chunk is
// warped by its own 2x3 matrix (m1 = m4 = 0) exactly as warpPlaneBilinear warps a chunk
// with that matrix; a chunk that matrix's warp would not take on the fast path (taps off
// the frame, a step the window trick does not handle) is sampled per pixel with it, and the
// columns past the last whole chunk per pixel at WarpMesh::at. So any mesh is handled. The
// lane offsets come from the chunk's m0 rounded to 2^-25 and m3 to 2^-19 (the same as the
// matrix warp's whenever they are multiples of those; else an offset may differ by 1/1024
// px: on an affine mesh with arbitrary entries about 7 bytes in 10^5 differ from the matrix
// warp's). Cost: the AVX2 kernel plans a row's chunks in one pass from the row's nodes
// (about half of the mesh warp's time) and spends three 16-bit multiplies per chunk vector
// on its offsets; the 1080p I420 frame of `uavstab-bench-lens --only cost` (150-degree
// fisheye, 16-px cells, chroma planes paired by warpPlanePairBilinearMesh; one thread, the
// meshes, 0.22 ms, included) takes 1.80-1.84x the single-matrix warp's CPU time on a
// Zen 5 (where the single-matrix warp is 0.93 ms); the mesh warp alone about 1.6x.
bool warpPlaneBilinearMesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const WarpMesh &mesh, bool replicate,
                           const std::uint8_t border[4]);
// The same with a given kernel (tests); false also when the kernel is not available.
bool warpPlaneBilinearMesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                           int row_end, int channels, const WarpMesh &mesh, bool replicate,
                           const std::uint8_t border[4], WarpKernel kernel);

// One plane of warpPlanePairBilinearMesh: its source, destination rows and their border.
struct MeshWarpPlane {
    PlaneSpan src;
    std::uint8_t *dst;
    int dst_stride;
    const std::uint8_t *border;
};

// Two 1-byte planes of one size through one mesh (I420's chroma planes): in each the bytes
// warpPlaneBilinearMesh writes. The AVX2 kernel plans each row's chunks and their taps
// once for both (the plan is half of a chunk's cost); the others warp one plane after the
// other. False, having written nothing, as warpPlaneBilinearMesh, and when the sources'
// sizes differ.
bool warpPlanePairBilinearMesh(const MeshWarpPlane &a, const MeshWarpPlane &b, int dst_width, int row_begin,
                               int row_end, const WarpMesh &mesh, bool replicate);
bool warpPlanePairBilinearMesh(const MeshWarpPlane &a, const MeshWarpPlane &b, int dst_width, int row_begin,
                               int row_end, const WarpMesh &mesh, bool replicate, WarpKernel kernel);

// 4 interleaved bytes per pixel at WarpMesh::at rounded to 1/32 px and weighted as OpenCV's
// fixed-point bilinear (warpPlaneBilinear4's arithmetic). The positions: in a cell whose
// nodes lie within +-29000 px, in fixed point (each row's nodes rounded to 2^-24 px, a
// per-pixel step floor((right - left) / cell) of those units), within ~1e-6 px of at()'s
// doubles (the bench's fisheye frame: 6 bytes in 8.3 million differ from rounding at()'s
// doubles, by 1); elsewhere at()'s doubles. The AVX2 kernel (where this CPU has it) takes
// eight pixels at a time as warpPlaneBilinear4 does, a row's cells planned four at a time
// (A, a, D in 32-bit lanes) and its positions a 32-bit add and shift per eight per axis:
// the bench's 1080p BGRx frame (`uavstab-bench-lens --only cost`, meshes included) takes
// 1.22-1.32x the single-matrix cost, median of 12 runs 1.26x (was 1.97-2.32x, median 2.06x:
// double positions, the window taps not inlined; same command, alternated on the same
// noisy machine); the scalar one (also the reference the tests compare it with) per pixel,
// over ten times that. A kernel given: false when it is not available or is Simd128 (there
// is none).
bool warpPlaneBilinear4Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4]);
bool warpPlaneBilinear4Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4],
                            WarpKernel kernel);
// 3 bytes per pixel: per pixel with the same arithmetic (no vector kernel).
bool warpPlaneBilinear3Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                            int row_end, const WarpMesh &mesh, bool replicate, const std::uint8_t border[4]);

// 16-bit samples, per pixel at WarpMesh::at, with warpPlaneBilinear16's arithmetic and border
// (a bounds check per tap: somewhat dearer than its single-matrix inner loop).
bool warpPlaneBilinear16Mesh(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                             int row_end, const WarpMesh &mesh, bool replicate, std::uint16_t border, bool swap);

} // namespace uavstab
