// A fixed set of threads running submitted tasks in FIFO order.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace uavstab {

class WorkerPool {
public:
    explicit WorkerPool(int threads);
    // Runs every task already submitted, then joins. Tasks may still submit while it
    // runs; owners whose tasks reach back into them call waitIdle() first.
    ~WorkerPool();
    WorkerPool(const WorkerPool &) = delete;
    WorkerPool &operator=(const WorkerPool &) = delete;

    void submit(std::function<void()> task);
    // Runs work(chunk, lane) for every chunk in [0, chunks): the caller (lane 0) and, if
    // one is free before the caller is done, a worker (lane 1) take chunks in turn.
    // Returns when every chunk is done, rethrowing the first exception. Never waits
    // behind queued tasks: a worker busy with them simply does not join in.
    void share(int chunks, const std::function<void(int chunk, int lane)> &work);
    // Returns once no task is queued or running: tasks submitted by running tasks are
    // waited for too, since they are queued before their submitter finishes.
    void waitIdle();
    int size() const { return int(threads_.size()); }

private:
    void run();

    std::mutex mutex_;
    std::condition_variable wake_;
    std::condition_variable idle_;
    std::deque<std::function<void()>> tasks_;
    int running_ = 0;
    bool stopping_ = false;
    std::vector<std::thread> threads_;
};

} // namespace uavstab
