#include "registration.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace bench {

namespace {
constexpr int kMaxWidth = 1280;
constexpr double kRatio = 0.8;
constexpr double kRansacPx = 1.5;  // in full-resolution pixels
} // namespace

FeatureExtractor::FeatureExtractor(int max_features, double border)
    // Two pyramid levels only: coarse levels' keypoints are too coarsely placed for a
    // sub-pixel measurement (8 levels: 0.28 px RMS corner error on the synthetic flight;
    // 2 levels + cornerSubPix: 0.05 px), and the scale changes met here are below 10 %.
    : orb_(cv::ORB::create(max_features, 1.2f, 2, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 10)), border_(border)
{
}

Features FeatureExtractor::extract(const cv::Mat &gray) const
{
    Features f;
    f.width = gray.cols;
    f.height = gray.rows;
    cv::Mat small = gray;
    double scale = 1.0;
    if (gray.cols > kMaxWidth) {
        scale = double(gray.cols) / kMaxWidth;
        cv::resize(gray, small, cv::Size(kMaxWidth, int(std::lround(gray.rows / scale))), 0, 0, cv::INTER_AREA);
    }
    cv::Mat mask = cv::Mat::zeros(small.size(), CV_8U);
    const int bx = int(small.cols * border_), by = int(small.rows * border_);
    mask(cv::Rect(bx, by, small.cols - 2 * bx, small.rows - 2 * by)).setTo(255);
    std::vector<cv::KeyPoint> keypoints;
    orb_->detectAndCompute(small, mask, keypoints, f.descriptors);
    std::vector<cv::Point2f> refined;
    cv::KeyPoint::convert(keypoints, refined);
    if (!refined.empty())
        cv::cornerSubPix(small, refined, cv::Size(3, 3), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01));
    const double sx = double(gray.cols) / small.cols, sy = double(gray.rows) / small.rows;
    f.points.reserve(keypoints.size());
    for (const auto &p : refined)
        f.points.emplace_back(float((p.x + 0.5) * sx - 0.5), float((p.y + 0.5) * sy - 0.5));
    return f;
}

uavstab::Similarity similarityFromPixelAffine(const cv::Matx23d &m, int width, int height)
{
    // p_to = A p_from + t in pixels; centred q = p - c:  q_to = A q_from + (A c + t - c).
    const double cx = (width - 1) * 0.5, cy = (height - 1) * 0.5;
    uavstab::Similarity s;
    const double a = 0.5 * (m(0, 0) + m(1, 1)), b = 0.5 * (m(1, 0) - m(0, 1));
    s.scale = std::hypot(a, b);
    s.angle = std::atan2(b, a);
    s.dx = m(0, 0) * cx + m(0, 1) * cy + m(0, 2) - cx;
    s.dy = m(1, 0) * cx + m(1, 1) * cy + m(1, 2) - cy;
    return s;
}

void singularValues(const cv::Matx23d &m, double *s1, double *s2)
{
    const cv::Matx22d a(m(0, 0), m(0, 1), m(1, 0), m(1, 1));
    cv::Mat w;
    cv::SVD::compute(cv::Mat(a), w, cv::SVD::NO_UV);
    *s1 = w.at<double>(0);
    *s2 = w.at<double>(1);
}

Registration registerFeatures(const Features &from, const Features &to)
{
    Registration r;
    if (from.descriptors.empty() || to.descriptors.empty() || from.points.size() < 8 || to.points.size() < 8)
        return r;
    cv::BFMatcher matcher(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(from.descriptors, to.descriptors, knn, 2);
    std::vector<cv::Point2f> a, b;
    for (const auto &m : knn) {
        if (m.size() < 2 || m[0].distance > kRatio * m[1].distance)
            continue;
        a.push_back(from.points[std::size_t(m[0].queryIdx)]);
        b.push_back(to.points[std::size_t(m[0].trainIdx)]);
    }
    r.matches = int(a.size());
    if (a.size() < 8)
        return r;
    std::vector<uchar> inliers;
    const cv::Mat partial = cv::estimateAffinePartial2D(a, b, inliers, cv::RANSAC, kRansacPx, 4000, 0.999, 20);
    if (partial.empty())
        return r;
    r.inliers = int(std::count(inliers.begin(), inliers.end(), uchar(1)));
    if (r.inliers < 8)
        return r;
    const cv::Matx23d pm(partial);
    r.similarity = similarityFromPixelAffine(pm, from.width, from.height);
    // The full affine, fitted to the similarity's inliers (least squares after RANSAC).
    std::vector<cv::Point2f> ia, ib;
    for (std::size_t i = 0; i < inliers.size(); ++i)
        if (inliers[i]) {
            ia.push_back(a[i]);
            ib.push_back(b[i]);
        }
    std::vector<uchar> inliers2;
    const cv::Mat full = cv::estimateAffine2D(ia, ib, inliers2, cv::RANSAC, kRansacPx, 2000, 0.999, 20);
    r.affine = full.empty() ? pm : cv::Matx23d(full);
    r.ok = true;
    return r;
}

} // namespace bench
