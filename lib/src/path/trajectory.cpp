#include "path/trajectory.hpp"

#include <algorithm>
#include <stdexcept>

namespace uavstab {

std::int64_t Trajectory::append(const Similarity &motion, bool new_segment)
{
    const std::int64_t index = next();
    if (new_segment || entries_.empty()) {
        ++segment_;
        entries_.push_back({Similarity::identity(), segment_});
        return index;
    }
    entries_.push_back({entries_.back().pose * motion, segment_});
    return index;
}

const Similarity &Trajectory::pose(std::int64_t index) const
{
    if (index < first_ || index >= next())
        throw std::out_of_range("Trajectory::pose: frame not held");
    return entries_[std::size_t(index - first_)].pose;
}

std::vector<Similarity> Trajectory::window(std::int64_t index, int radius, std::size_t *centre) const
{
    if (index < first_ || index >= next())
        throw std::out_of_range("Trajectory::window: frame not held");
    const std::int64_t segment = entries_[std::size_t(index - first_)].segment;
    std::int64_t lo = std::max(first_, index - radius);
    std::int64_t hi = std::min(next() - 1, index + radius);
    while (entries_[std::size_t(lo - first_)].segment != segment)
        ++lo;
    while (entries_[std::size_t(hi - first_)].segment != segment)
        --hi;
    std::vector<Similarity> poses;
    poses.reserve(std::size_t(hi - lo + 1));
    for (std::int64_t i = lo; i <= hi; ++i)
        poses.push_back(entries_[std::size_t(i - first_)].pose);
    *centre = std::size_t(index - lo);
    return poses;
}

std::vector<Similarity> Trajectory::lookahead(std::int64_t index, int count) const
{
    if (index < first_ || index >= next())
        throw std::out_of_range("Trajectory::lookahead: frame not held");
    const std::int64_t segment = entries_[std::size_t(index - first_)].segment;
    const std::int64_t last = std::min(next() - 1, index + std::max(0, count));
    std::vector<Similarity> poses;
    poses.reserve(std::size_t(last - index + 1));
    for (std::int64_t i = index; i <= last && entries_[std::size_t(i - first_)].segment == segment; ++i)
        poses.push_back(entries_[std::size_t(i - first_)].pose);
    return poses;
}

void Trajectory::dropBefore(std::int64_t index)
{
    // The newest pose is always kept: the next frame's pose is composed from it.
    while (entries_.size() > 1 && first_ < index) {
        entries_.pop_front();
        ++first_;
    }
}

void Trajectory::clear()
{
    entries_.clear();
    first_ = 0;
    ++segment_;
}

} // namespace uavstab
