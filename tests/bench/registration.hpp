// Motion between two frames measured independently of the stabilizer's own tracker:
// ORB features (OpenCV features2d), brute-force Hamming matching with a ratio test, then
// RANSAC fits (calib3d): a similarity (estimateAffinePartial2D) and a full affine
// (estimateAffine2D) on the same matches.
#pragma once

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "uavstab/similarity.hpp"

namespace bench {

// ORB features of one frame (luma), detected on a grey image shrunk to at most 1280
// pixels wide, positions refined with cornerSubPix; coordinates are given back in
// full-resolution pixels.
struct Features {
    std::vector<cv::Point2f> points;  // full-resolution pixels
    cv::Mat descriptors;
    int width = 0, height = 0;
};

class FeatureExtractor {
public:
    // `border`: share of width/height at each edge where no features are taken
    // (stabilized frames may have black or mirrored borders there).
    explicit FeatureExtractor(int max_features = 1200, double border = 0.06);
    Features extract(const cv::Mat &gray) const;

private:
    cv::Ptr<cv::ORB> orb_;
    double border_;
};

struct Registration {
    bool ok = false;
    uavstab::Similarity similarity;  // centred coordinates, from -> to
    cv::Matx23d affine;              // pixel coordinates, from -> to (full 6 DOF)
    int matches = 0;
    int inliers = 0;
};

// Transform taking `from`'s pixels onto `to`'s.
Registration registerFeatures(const Features &from, const Features &to);

// Centred similarity from a 2x3 pixel-coordinate partial affine of a width x height frame.
uavstab::Similarity similarityFromPixelAffine(const cv::Matx23d &m, int width, int height);

// Singular values (s1 >= s2) of the 2x2 linear part.
void singularValues(const cv::Matx23d &m, double *s1, double *s2);

} // namespace bench
