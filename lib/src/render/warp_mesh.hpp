// A non-linear output -> input map (lens correction composed with stabilization) sampled
// on a coarse grid of output pixels: the warp kernels interpolate it bilinearly between
// nodes, so that the map itself is evaluated once per node rather than once per pixel.
#pragma once

#include <functional>
#include <vector>

#include "uavstab/similarity.hpp"

namespace uavstab {

// Source positions on a coarse grid of one plane's output pixels: node (i, j) sits at
// output pixel (i * cell, j * cell); the nodes cover the plane: columns =
// ceil((width - 1) / cell) + 1 (at least 2), rows likewise.
struct WarpMesh {
    int cell = 16;
    int columns = 0, rows = 0;
    std::vector<double> x, y;  // node (i, j) at [j * columns + i]

    // Bilinear between nodes: first down the two node rows around oy, then along the row
    // (the reference the kernels follow). Beyond the last node the last cell extends.
    Point2 at(double ox, double oy) const;
    // Every node column's position at output row oy, as at() interpolates it down the
    // column (row_x, row_y: `columns` entries each). Along the row, inside a cell, at()
    // is then linear between two of these.
    void rowAt(double oy, double *row_x, double *row_y) const;
    // The node row j that rowAt interpolates from (with j + 1) at output row oy, and oy's
    // fraction t between them: row_x[i] = x[j columns + i] + (x[(j + 1) columns + i] -
    // x[j columns + i]) t, and likewise y.
    void rowCell(double oy, int &j, double &t) const;
    // The position at output column ox of the row whose node positions rowAt gave: the
    // same doubles as at(ox, oy) for that row's oy, without interpolating down every time.
    Point2 alongRow(const double *row_x, const double *row_y, double ox) const;
    // Whether the nodes reach every pixel of a width x height plane.
    bool covers(int width, int height) const;
};

// Samples `output_to_input` (output pixel -> source pixel, both in that plane's pixels) at
// the nodes of a mesh covering a width x height plane. The cell must be a positive multiple
// of 16 (the kernels' chunk) and the plane at least 1 x 1: else std::invalid_argument.
WarpMesh makeWarpMesh(int width, int height, int cell, const std::function<Point2(Point2)> &output_to_input);

// The mesh of `cell`-px cells covering a width x height plane interpolated from a coarser
// one: every node at coarse.at()'s doubles. The cell and the plane as makeWarpMesh's (else
// std::invalid_argument).
WarpMesh refineWarpMesh(const WarpMesh &coarse, int width, int height, int cell);

} // namespace uavstab
