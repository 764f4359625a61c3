#include "worker_pool.hpp"

#include <atomic>
#include <exception>
#include <memory>

namespace uavstab {

WorkerPool::WorkerPool(int threads)
{
    for (int i = 0; i < (threads < 1 ? 1 : threads); ++i)
        threads_.emplace_back([this] { run(); });
}

WorkerPool::~WorkerPool()
{
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    for (auto &t : threads_)
        t.join();
}

void WorkerPool::submit(std::function<void()> task)
{
    {
        std::lock_guard<std::mutex> lock(mutex_);
        tasks_.push_back(std::move(task));
    }
    wake_.notify_one();
}

void WorkerPool::share(int chunks, const std::function<void(int chunk, int lane)> &work)
{
    // The queued helper may outlive this call (when it starts after the caller finished):
    // it then finds no chunk left and holds only the shared state.
    struct Shared {
        std::atomic<int> next{0};
        std::atomic<bool> closed{false};  // set by the caller once done; a helper starting later leaves
        int chunks = 0;
        const std::function<void(int, int)> *work = nullptr;
        std::mutex mutex;
        std::condition_variable done_cv;
        bool helper_done = false;
        std::exception_ptr error;
    };
    auto shared = std::make_shared<Shared>();
    shared->chunks = chunks;
    shared->work = &work;
    auto take = [](Shared &s, int lane) {
        std::exception_ptr error;
        for (int chunk; (chunk = s.next.fetch_add(1)) < s.chunks;) {
            try {
                (*s.work)(chunk, lane);
            } catch (...) {
                error = std::current_exception();
                s.next.store(s.chunks);  // the others stop too
            }
        }
        return error;
    };
    if (chunks > 1) {
        submit([shared, take] {
            if (shared->closed.exchange(true))
                return;
            std::exception_ptr error = take(*shared, 1);
            std::lock_guard<std::mutex> lock(shared->mutex);
            shared->error = error;
            shared->helper_done = true;
            shared->done_cv.notify_one();
        });
    }
    std::exception_ptr error = take(*shared, 0);
    if (chunks > 1 && shared->closed.exchange(true)) {
        // The helper started: wait for its last chunk.
        std::unique_lock<std::mutex> lock(shared->mutex);
        shared->done_cv.wait(lock, [&] { return shared->helper_done; });
        if (!error)
            error = shared->error;
    }
    if (error)
        std::rethrow_exception(error);
}

void WorkerPool::waitIdle()
{
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return tasks_.empty() && running_ == 0; });
}

void WorkerPool::run()
{
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        wake_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
        if (tasks_.empty())
            return;  // stopping, and nothing left to run
        std::function<void()> task = std::move(tasks_.front());
        tasks_.pop_front();
        ++running_;
        lock.unlock();
        task();
        task = nullptr;  // whatever the task holds is released before it counts as done
        lock.lock();
        if (--running_ == 0 && tasks_.empty())
            idle_.notify_all();
    }
}

} // namespace uavstab
