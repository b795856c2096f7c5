#include "deformation/parallel.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace diffreg::parallel {
namespace {

// True on pool workers and inside a loop: a nested forChunks() then runs serially.
thread_local bool insideLoop = false;

// One loop in flight: chunks are claimed through an atomic counter, so the caller finishes every
// chunk no worker has claimed and never waits for a worker that has not joined.
struct Job {
  const std::function<void(int, int, int)>* body = nullptr;
  int n = 0, grain = 1, chunks = 0;
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;  // guarded by the pool's mutex
};

class Pool {
 public:
  Pool() {
    const unsigned hw = std::thread::hardware_concurrency();
    size_ = static_cast<int>(std::clamp(hw == 0 ? 1u : hw, 1u, 8u));
    for (int i = 1; i < size_; ++i) workers_.emplace_back([this] { work(); });
  }
  ~Pool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  int size() const { return size_; }

  /// False (and nothing run) when another thread's loop holds the pool.
  bool tryRun(Job& job) {
    std::unique_lock<std::mutex> busy(busy_, std::try_to_lock);
    if (!busy.owns_lock()) return false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = &job;
      ++generation_;
    }
    wake_.notify_all();
    runChunks(job);
    std::unique_lock<std::mutex> lock(mutex_);
    job_ = nullptr;  // late workers no longer join
    done_.wait(lock, [this] { return joined_ == 0; });
    if (job.error) std::rethrow_exception(job.error);
    return true;
  }

 private:
  void runChunks(Job& job) {
    for (int c = job.next.fetch_add(1); c < job.chunks; c = job.next.fetch_add(1)) {
      if (job.failed.load(std::memory_order_relaxed)) continue;
      try {
        const int begin = c * job.grain;
        (*job.body)(c, begin, std::min(job.n, begin + job.grain));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!job.error) job.error = std::current_exception();
        job.failed = true;
      }
    }
  }

  void work() {
    insideLoop = true;
    unsigned long seen = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [&] { return stop_ || (generation_ != seen && job_ != nullptr); });
      if (stop_) return;
      seen = generation_;
      Job* job = job_;
      ++joined_;
      lock.unlock();
      runChunks(*job);
      lock.lock();
      if (--joined_ == 0) done_.notify_all();
    }
  }

  int size_ = 1;
  std::vector<std::thread> workers_;
  std::mutex busy_;  // one loop at a time
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  Job* job_ = nullptr;
  unsigned long generation_ = 0;
  int joined_ = 0;
  bool stop_ = false;
};

Pool& pool() {
  static Pool p;
  return p;
}

}  // namespace

int numChunks(int n, int grain) { return n <= 0 ? 1 : (n + grain - 1) / grain; }

int threads() { return pool().size(); }

void forChunks(int n, int grain, const std::function<void(int, int, int)>& body) {
  if (n <= 0) return;
  const int chunks = numChunks(n, grain);
  if (chunks == 1 || insideLoop || threads() == 1) {
    for (int c = 0; c < chunks; ++c) body(c, c * grain, std::min(n, (c + 1) * grain));
    return;
  }
  Job job;
  job.body = &body;
  job.n = n;
  job.grain = grain;
  job.chunks = chunks;
  insideLoop = true;
  bool ran = false;
  try {
    ran = pool().tryRun(job);
  } catch (...) {
    insideLoop = false;
    throw;
  }
  insideLoop = false;
  if (!ran)  // another thread's loop has the pool: run this one here
    for (int c = 0; c < chunks; ++c) body(c, c * grain, std::min(n, (c + 1) * grain));
}

}  // namespace diffreg::parallel
