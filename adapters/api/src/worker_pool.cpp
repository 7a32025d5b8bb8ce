#include "nnb/worker_pool.hpp"

#include <algorithm>
#include <system_error>

namespace nnb {

namespace {
// The caller's wait at finish() is short (the helpers are past the batch's last barrier): it spins this
// many times before it sleeps.
constexpr int kSpinsBeforeSleep = 1 << 14;

// The calling thread's pools; the first `in_use` serve its batches under way (nested ones: last in, first
// out). In a child forked from a process that had pools, the pools' threads were not forked with them:
// those pools are let go without being touched (their mutexes and condition variables may be in any
// state), never joined or destroyed.
void let_go_if_forked(std::unique_ptr<WorkerPool>& pool) {
  if (pool && pool->forked()) (void)pool.release();
}

struct Pools {
  std::vector<std::unique_ptr<WorkerPool>> list;
  std::size_t in_use = 0;
  ~Pools() {
    for (auto& pool : list) let_go_if_forked(pool);
  }
};
thread_local Pools pools;
}  // namespace

WorkerPool::ForBatch::ForBatch() {
  if (pools.in_use == pools.list.size()) pools.list.push_back(nullptr);
  std::unique_ptr<WorkerPool>& pool = pools.list[pools.in_use];
  let_go_if_forked(pool);
  if (!pool) pool = std::make_unique<WorkerPool>();
  pool_ = pool.get();
  ++pools.in_use;
}

WorkerPool::ForBatch::~ForBatch() { --pools.in_use; }

int WorkerPool::start(int helpers, const std::function<void(int)>& job) {
  while (static_cast<int>(threads_.size()) < helpers) {
    try {
      threads_.emplace_back(&WorkerPool::serve, this, static_cast<int>(threads_.size()) + 1, round_);
    } catch (const std::system_error&) {
      break;  // no more threads to be had: those there are do the work
    }
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    job_ = &job;
    helpers_ = std::min(helpers, static_cast<int>(threads_.size()));
    running_.store(helpers_, std::memory_order_relaxed);
    ++round_;
  }
  wake_.notify_all();
  return helpers_;
}

void WorkerPool::finish() {
  for (int spins = 0; running_.load(std::memory_order_acquire) != 0; ++spins) {
    if (spins < kSpinsBeforeSleep) continue;
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return running_.load(std::memory_order_acquire) == 0; });
  }
}

void WorkerPool::serve(int member, unsigned round_seen) {
  for (;;) {
    const std::function<void(int)>* job = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || round_ != round_seen; });
      if (stop_) return;
      round_seen = round_;
      if (member > helpers_) continue;  // this round needs fewer threads
      job = job_;
    }
    (*job)(member);
    const std::lock_guard<std::mutex> lock(mutex_);
    if (running_.fetch_sub(1, std::memory_order_acq_rel) == 1) done_.notify_one();
  }
}

WorkerPool::~WorkerPool() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& thread : threads_) thread.join();
}

}  // namespace nnb
