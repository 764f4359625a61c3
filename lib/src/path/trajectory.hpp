// The accumulated camera path: pose of every recent frame, composed from the per-frame
// motions, split into segments at discontinuities (scene cuts, gaps, resets) so that a
// smoothing window never mixes two unrelated stretches of video.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "uavstab/similarity.hpp"

namespace uavstab {

class Trajectory {
public:
    // Appends the next frame, given its motion (this frame -> previous frame), and
    // returns the frame's index. A new segment starts at identity.
    std::int64_t append(const Similarity &motion, bool new_segment);

    // Pose of a frame: maps its centred coordinates into those of its segment's first frame.
    const Similarity &pose(std::int64_t index) const;

    // Poses of frames index-radius .. index+radius that exist and share index's segment;
    // *centre receives index's position in the result.
    std::vector<Similarity> window(std::int64_t index, int radius, std::size_t *centre) const;

    // Poses of frames index .. index+count that exist and share index's segment (at least
    // index's own).
    std::vector<Similarity> lookahead(std::int64_t index, int count) const;

    // Forgets frames before `index` (they will never be in a window again); the newest
    // frame is kept so that the path goes on.
    void dropBefore(std::int64_t index);
    void clear();

    std::int64_t next() const { return first_ + std::int64_t(entries_.size()); }
    bool empty() const { return entries_.empty(); }

private:
    struct Entry {
        Similarity pose;
        std::int64_t segment;
    };
    std::deque<Entry> entries_;
    std::int64_t first_ = 0;  // index of entries_.front()
    std::int64_t segment_ = 0;
};

} // namespace uavstab
