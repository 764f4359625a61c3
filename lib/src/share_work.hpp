// How the estimator shares its work with a host's idle thread.
#pragma once

#include <functional>

namespace uavstab {

// Runs work(chunk, lane) once for every chunk in [0, chunks): on the caller's thread
// (lane 0) and, when one is free, on one more thread at the same time (lane 1); returns
// when all are done, rethrowing the first exception any threw. Each lane has scratch of its
// own and each chunk writes only its own outputs, so the results do not depend on who ran
// what. Unset, the caller runs every chunk itself.
using ShareWork = std::function<void(int chunks, const std::function<void(int chunk, int lane)> &work)>;
constexpr int kShareWorkLanes = 2;

// Runs `work` through `share` when set, else every chunk on lane 0.
inline void runShared(const ShareWork &share, int chunks, const std::function<void(int chunk, int lane)> &work)
{
    if (share) {
        share(chunks, work);
        return;
    }
    for (int chunk = 0; chunk < chunks; ++chunk)
        work(chunk, 0);
}

} // namespace uavstab
