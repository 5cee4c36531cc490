#pragma once
// Runs assembly loops on a fixed number of threads (TBB): a conflict-free ElementSchedule,
// independent index ranges, and accumulation into per-thread private copies. Written once
// for every discretisation.
//
// Bodies receive whole ranges, not single elements, so that a body can set up its scratch
// space (ElementScratch, element_scratch.hpp) once per range and reuse it across the range's
// elements: per call that is one set of buffers per range, never one per element, and no
// state outlives the call (a const discretisation stays safe to share between threads).
#include <functional>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "discretizations/assembly/element_schedule.hpp"

namespace twill {

class ParallelRunner {
 public:
  /// `threads` workers; 0 = TBB's choice, 1 = everything serial in the calling thread.
  explicit ParallelRunner(int threads = 0);
  ~ParallelRunner();
  ParallelRunner(const ParallelRunner&) = delete;
  ParallelRunner& operator=(const ParallelRunner&) = delete;

  int threads() const { return threads_; }

  /// Runs `schedule`: phase after phase; within a phase, ranges of whole groups concurrently,
  /// each range's elements in order by one call body(elements).
  void run(const ElementSchedule& schedule,
           const std::function<void(std::span<const int> elements)>& body) const;

  /// body(begin, end) over [0, n) in chunks of at least `grain` items, concurrently from
  /// `parallel_minimum` indices on (serially below: scheduling would cost more). Every index
  /// must write only its own outputs.
  void for_each_range(int n, int grain, int parallel_minimum,
                      const std::function<void(int begin, int end)>& body) const;

  /// Private copies: every worker adds into its own zeroed copies of `targets` (pointer,
  /// length); the copies are summed into the targets at the end. body(begin, end, outputs)
  /// over [0, n), with outputs[t] the copy of targets[t]. The summation order depends on the
  /// split between threads: results agree to round-off only.
  void run_with_private_copies(
      int n, const std::vector<std::pair<double*, std::size_t>>& targets,
      const std::function<void(int begin, int end, double* const* outputs)>& body) const;

 private:
  struct Arena;
  int threads_ = 0;
  // The TBB arena that bounds the worker count. It holds no state of any evaluation, and
  // entering it (task_arena::execute) is thread-safe, so const calls from several threads
  // may share one runner.
  std::unique_ptr<Arena> arena_;
};

}  // namespace twill
