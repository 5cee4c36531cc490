#include "discretizations/assembly/parallel_runner.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace twill {

struct ParallelRunner::Arena {
  tbb::task_arena arena;

  /// Chunk size for n equal-cost items: about 4 chunks per worker, so that a body (and the
  /// scratch it sets up) sees many items at once while stealing still balances the load.
  /// TBB's auto partitioner would call a body on single items here.
  int chunk(int n) const { return std::max(1, n / (4 * std::max(1, arena.max_concurrency()))); }
};

ParallelRunner::ParallelRunner(int threads) : threads_(threads), arena_(std::make_unique<Arena>()) {
  if (threads > 0)
    arena_->arena.initialize(threads);
  else
    arena_->arena.initialize();
}

ParallelRunner::~ParallelRunner() = default;

void ParallelRunner::run(const ElementSchedule& schedule,
                         const std::function<void(std::span<const int>)>& body) const {
  for (int phase = 0; phase < schedule.num_phases(); ++phase) {
    const int groups = schedule.num_groups(phase);
    if (threads_ == 1 || groups < 2) {
      if (groups > 0) body(schedule.groups(phase, 0, groups));
      continue;
    }
    arena_->arena.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<int>(0, groups, static_cast<std::size_t>(arena_->chunk(groups))),
          [&](const tbb::blocked_range<int>& r) { body(schedule.groups(phase, r.begin(), r.end())); },
          tbb::simple_partitioner());
    });
  }
}

void ParallelRunner::for_each_range(int n, int grain, int parallel_minimum,
                                    const std::function<void(int, int)>& body) const {
  if (n <= 0) return;
  if (threads_ == 1 || n < parallel_minimum) {
    body(0, n);
    return;
  }
  const int chunk = std::max(grain, arena_->chunk(n));
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, n, static_cast<std::size_t>(chunk)),
                      [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end()); },
                      tbb::simple_partitioner());
  });
}

void ParallelRunner::run_with_private_copies(
    int n, const std::vector<std::pair<double*, std::size_t>>& targets,
    const std::function<void(int, int, double* const*)>& body) const {
  arena_->arena.execute([&] {
    struct Copies {
      std::vector<std::vector<double>> buffers;
      std::vector<double*> outputs;
    };
    tbb::enumerable_thread_specific<Copies> local([&] {
      Copies copies;
      for (const auto& t : targets) copies.buffers.emplace_back(t.second, 0.0);
      for (auto& b : copies.buffers) copies.outputs.push_back(b.data());
      return copies;
    });
    tbb::parallel_for(
        tbb::blocked_range<int>(0, n, static_cast<std::size_t>(arena_->chunk(n))),
        [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end(), local.local().outputs.data()); },
        tbb::simple_partitioner());
    for (std::size_t t = 0; t < targets.size(); ++t)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, targets[t].second),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          for (const Copies& copies : local)
                            for (std::size_t i = r.begin(); i != r.end(); ++i)
                              targets[t].first[i] += copies.buffers[t][i];
                        });
  });
}

}  // namespace twill
