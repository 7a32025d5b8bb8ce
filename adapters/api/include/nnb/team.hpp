#pragma once
// The threads answering one batch together. Each runs the same code with its own member number, in
// phases: phase(body) runs body on this member, then waits until every member has finished the phase (a
// barrier), so that one start of the team serves every step of a batch (ordering the queries, answering
// slices, returning the rows) and what a member wrote in a phase is seen by all in the next. A body that
// throws still reaches the barrier (no member waits forever); the first exception is kept for the caller,
// and later bodies are skipped.
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

namespace nnb {

class Team {
 public:
  /// What the members share; size is set once every member's thread is running.
  struct Shared {
    std::atomic<int> size{0};
    std::atomic<int> arrived{0};
    std::atomic<unsigned> generation{0};
    std::atomic<bool> failed{false};
    std::mutex error_mutex;
    std::exception_ptr error;  ///< the first a body threw; read it once the members have finished
    void* scratch = nullptr;  ///< one object member 0 may publish to the others (see scratch())
  };

  /// Waits until the team's size is known.
  Team(int member, Shared& shared) : member_(member), shared_(shared) {
    for (int spins = 0; (size_ = shared_.size.load(std::memory_order_acquire)) == 0; ++spins) pause(spins);
  }

  /// This thread's number, 0 (the caller's thread) to size() - 1.
  int member() const { return member_; }
  int size() const { return size_; }

  /// This member's share [first, second) of n items split evenly.
  std::pair<std::size_t, std::size_t> share(std::size_t n) const {
    return {n * std::size_t(member_) / std::size_t(size_), n * std::size_t(member_ + 1) / std::size_t(size_)};
  }

  /// Runs body on this member unless a member failed, then waits for every member to finish the phase.
  template <class Body>
  void phase(Body&& body) const {
    if (!shared_.failed.load(std::memory_order_relaxed)) {
      try {
        body();
      } catch (...) {
        fail(std::current_exception());
      }
    }
    sync();
  }

  /// Member 0's object of type T, published in an earlier phase with publish(): memory the members fill
  /// together (each its share). Null if it was not published (its phase failed: later bodies are skipped).
  template <class T>
  T* scratch() const { return static_cast<T*>(shared_.scratch); }
  /// Called by member 0 in a phase; the others may use scratch<T>() from the next phase on.
  template <class T>
  void publish(T& object) const { shared_.scratch = &object; }

 private:
  void fail(std::exception_ptr error) const {
    std::lock_guard<std::mutex> lock(shared_.error_mutex);
    if (!shared_.error) shared_.error = error;
    shared_.failed.store(true, std::memory_order_relaxed);
  }

  // A barrier: the last member to arrive starts the next generation.
  void sync() const {
    const unsigned generation = shared_.generation.load(std::memory_order_acquire);
    if (shared_.arrived.fetch_add(1, std::memory_order_acq_rel) + 1 == size_) {
      shared_.arrived.store(0, std::memory_order_relaxed);
      shared_.generation.fetch_add(1, std::memory_order_acq_rel);
      return;
    }
    for (int spins = 0; shared_.generation.load(std::memory_order_acquire) == generation; ++spins) pause(spins);
  }

  // Spins briefly, then yields: a team may have more threads than the machine has cores.
  static void pause(int spins) {
    if (spins >= kSpinsBeforeYield) std::this_thread::yield();
  }

  static constexpr int kSpinsBeforeYield = 1 << 12;
  int member_;
  int size_ = 0;
  Shared& shared_;
};

}  // namespace nnb
