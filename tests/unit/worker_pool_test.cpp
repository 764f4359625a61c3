// WorkerPool::share, which lends the estimator an idle worker: every chunk runs once, on
// the caller or one worker, and the caller never waits behind queued tasks.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <stdexcept>
#include <vector>

#include "worker_pool.hpp"

using namespace uavstab;

TEST(WorkerPool, SharedWorkRunsEveryChunkOnceOnTheCallerOrOneWorker)
{
    WorkerPool pool(2);
    int helped = 0;
    for (int round = 0; round < 300; ++round) {
        const int chunks = 1 + round % 40;
        std::vector<std::atomic<int>> runs(static_cast<std::size_t>(chunks));
        std::atomic<int> by_worker{0}, bad_lane{0};
        pool.share(chunks, [&](int chunk, int lane) {
            runs[std::size_t(chunk)].fetch_add(1);
            if (lane == 1)
                ++by_worker;
            else if (lane != 0)
                ++bad_lane;
            // A little work, so that a worker has time to join in.
            volatile double x = 0;
            for (int i = 0; i < 2000; ++i)
                x = x + i * 0.5;
        });
        for (int c = 0; c < chunks; ++c)
            ASSERT_EQ(runs[std::size_t(c)].load(), 1) << "chunk " << c << " of " << chunks << ", round " << round;
        EXPECT_EQ(bad_lane.load(), 0);
        helped += by_worker.load() > 0;
    }
    // Not asserted (a loaded machine may never wake a worker in time), but shown.
    std::printf("a worker joined in %d of 300 rounds\n", helped);
    pool.waitIdle();
}

TEST(WorkerPool, SharedWorkDoesNotWaitBehindABusyWorker)
{
    WorkerPool pool(1);
    std::promise<void> release;
    std::shared_future<void> released = release.get_future().share();
    pool.submit([released] { released.wait(); });  // the only worker is busy until released
    auto done = std::async(std::launch::async, [&] {
        int on_caller = 0;
        pool.share(8, [&](int, int lane) { on_caller += lane == 0; });
        return on_caller;
    });
    const bool finished = done.wait_for(std::chrono::seconds(20)) == std::future_status::ready;
    release.set_value();
    ASSERT_TRUE(finished) << "share() waited for the busy worker";
    EXPECT_EQ(done.get(), 8);
    pool.waitIdle();
}

TEST(WorkerPool, SharedWorkRethrowsAChunksExceptionAndThePoolGoesOn)
{
    WorkerPool pool(2);
    for (int round = 0; round < 50; ++round) {
        EXPECT_THROW(pool.share(16,
                                [](int chunk, int) {
                                    if (chunk == 5)
                                        throw std::runtime_error("chunk 5");
                                }),
                     std::runtime_error);
    }
    std::atomic<int> runs{0};
    pool.share(10, [&](int, int) { ++runs; });
    EXPECT_EQ(runs.load(), 10);
    pool.waitIdle();
}
