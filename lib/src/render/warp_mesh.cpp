#include "render/warp_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace uavstab {

namespace {

int nodesCovering(int pixels, int cell)
{
    return std::max(2, (pixels - 1 + cell - 1) / cell + 1);
}

// The cell [index, index + 1] holding output coordinate o, and o's fraction in it.
void cellOf(double o, int cell, int nodes, int &index, double &fraction)
{
    const double k = std::floor(o / cell);
    index = int(std::clamp(k, 0.0, double(nodes - 2)));
    fraction = (o - double(index) * cell) / cell;
}

} // namespace

void WarpMesh::rowCell(double oy, int &j, double &t) const
{
    cellOf(oy, cell, rows, j, t);
}

void WarpMesh::rowAt(double oy, double *row_x, double *row_y) const
{
    int j;
    double t;
    rowCell(oy, j, t);
    const double *top_x = x.data() + std::size_t(j) * columns, *top_y = y.data() + std::size_t(j) * columns;
    const double *bottom_x = top_x + columns, *bottom_y = top_y + columns;
    for (int i = 0; i < columns; ++i) {
        row_x[i] = top_x[i] + (bottom_x[i] - top_x[i]) * t;
        row_y[i] = top_y[i] + (bottom_y[i] - top_y[i]) * t;
    }
}

Point2 WarpMesh::at(double ox, double oy) const
{
    int i, j;
    double s, t;
    cellOf(ox, cell, columns, i, s);
    cellOf(oy, cell, rows, j, t);
    const std::size_t top = std::size_t(j) * columns + i, bottom = top + columns;
    // The same expressions as rowAt and alongRow, so that a kernel's row of nodes and at() agree.
    const double left_x = x[top] + (x[bottom] - x[top]) * t;
    const double left_y = y[top] + (y[bottom] - y[top]) * t;
    const double right_x = x[top + 1] + (x[bottom + 1] - x[top + 1]) * t;
    const double right_y = y[top + 1] + (y[bottom + 1] - y[top + 1]) * t;
    return {left_x + (right_x - left_x) * s, left_y + (right_y - left_y) * s};
}

Point2 WarpMesh::alongRow(const double *row_x, const double *row_y, double ox) const
{
    int i;
    double s;
    cellOf(ox, cell, columns, i, s);
    return {row_x[i] + (row_x[i + 1] - row_x[i]) * s, row_y[i] + (row_y[i + 1] - row_y[i]) * s};
}

bool WarpMesh::covers(int width, int height) const
{
    return cell > 0 && columns >= 2 && rows >= 2 && x.size() == std::size_t(columns) * std::size_t(rows) &&
           y.size() == x.size() && double(columns - 1) * cell >= width - 1 && double(rows - 1) * cell >= height - 1;
}

namespace {

// A mesh of `cell`-px cells covering a width x height plane, its nodes not yet set.
WarpMesh sizedMesh(const char *caller, int width, int height, int cell)
{
    if (cell <= 0 || cell % 16 != 0)
        throw std::invalid_argument(std::string(caller) + ": the cell must be a positive multiple of 16 pixels");
    if (width < 1 || height < 1)
        throw std::invalid_argument(std::string(caller) + ": empty plane");
    WarpMesh mesh;
    mesh.cell = cell;
    mesh.columns = nodesCovering(width, cell);
    mesh.rows = nodesCovering(height, cell);
    mesh.x.resize(std::size_t(mesh.columns) * std::size_t(mesh.rows));
    mesh.y.resize(mesh.x.size());
    return mesh;
}

} // namespace

WarpMesh refineWarpMesh(const WarpMesh &coarse, int width, int height, int cell)
{
    WarpMesh fine = sizedMesh("refineWarpMesh", width, height, cell);
    // Each fine column's coarse cell and fraction (cellOf's, found once rather than per node).
    std::vector<int> index(std::size_t(fine.columns));
    std::vector<double> fraction(index.size());
    for (int i = 0; i < fine.columns; ++i)
        cellOf(double(i) * cell, coarse.cell, coarse.columns, index[std::size_t(i)], fraction[std::size_t(i)]);
    std::vector<double> row_x(std::size_t(coarse.columns)), row_y(row_x.size());
    for (int j = 0; j < fine.rows; ++j) {
        coarse.rowAt(double(j) * cell, row_x.data(), row_y.data());
        double *x = fine.x.data() + std::size_t(j) * std::size_t(fine.columns);
        double *y = fine.y.data() + std::size_t(j) * std::size_t(fine.columns);
        for (std::size_t i = 0; i < index.size(); ++i) {
            const std::size_t k = std::size_t(index[i]);
            const double s = fraction[i];
            // alongRow's expressions.
            x[i] = row_x[k] + (row_x[k + 1] - row_x[k]) * s;
            y[i] = row_y[k] + (row_y[k + 1] - row_y[k]) * s;
        }
    }
    return fine;
}

WarpMesh makeWarpMesh(int width, int height, int cell, const std::function<Point2(Point2)> &output_to_input)
{
    WarpMesh mesh = sizedMesh("makeWarpMesh", width, height, cell);
    for (int j = 0; j < mesh.rows; ++j)
        for (int i = 0; i < mesh.columns; ++i) {
            const Point2 s = output_to_input({double(i) * cell, double(j) * cell});
            mesh.x[std::size_t(j) * mesh.columns + i] = s.x;
            mesh.y[std::size_t(j) * mesh.columns + i] = s.y;
        }
    return mesh;
}

} // namespace uavstab
