#pragma once
// Threads kept between batches. Starting a thread for each batch and joining it afterwards cost about a
// tenth of a millisecond a batch, a twentieth of a 60,000-query batch's time on two threads.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <unistd.h>

namespace nnb {

class WorkerPool {
 public:
  /// A pool of the calling thread's, for one batch: each thread that answers batches has its own helpers,
  /// so batches answered at once by different threads never wait for each other's, and a batch answered
  /// within a batch (an index computing what its search needs) gets a pool of its own.
  class ForBatch {
   public:
    ForBatch();
    ~ForBatch();
    ForBatch(const ForBatch&) = delete;
    ForBatch& operator=(const ForBatch&) = delete;
    WorkerPool& pool() const { return *pool_; }

   private:
    WorkerPool* pool_;
  };

  /// Runs job(1) ... job(helpers) on the pool's threads (started when first needed) and returns how many
  /// run: fewer when the system gives no more threads. finish() must follow before the next start().
  int start(int helpers, const std::function<void(int member)>& job);
  /// Waits until every job of the last start() has returned.
  void finish();

  /// Whether this process is a child forked from the one that made the pool.
  bool forked() const { return owner_ != ::getpid(); }

  WorkerPool() : owner_(::getpid()) {}
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  ~WorkerPool();

 private:
  void serve(int member, unsigned round_seen);

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> threads_;
  const std::function<void(int)>* job_ = nullptr;
  int helpers_ = 0;    ///< members 1 to helpers_ run the current round's job
  unsigned round_ = 0;  ///< counts start()s
  bool stop_ = false;
  std::atomic<int> running_{0};  ///< helpers whose job of this round has not returned
  pid_t owner_;
};

}  // namespace nnb
