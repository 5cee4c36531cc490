#pragma once
// Messages between the ranks of `mpirun -np K twill sweep …` (issue #17; docs/studies.md §4),
// through the MPI plugin the program loads at run time (study/mpi_shim/twill_mpi_shim.cpp
// says why it is not linked). Rank 0 owns the study and the database; the other ranks only
// run what it sends them.
#include <memory>
#include <optional>
#include <string>

namespace twill {

/// True when this process was started by an MPI launcher with more than one rank (Open MPI's
/// OMPI_COMM_WORLD_SIZE, PMIx's or PMI's environment, as mpirun and Slurm's srun set them).
bool launched_by_mpi();

struct MpiMessage {
  int source = 0;
  int tag = 0;
  std::string bytes;
};

class MpiTransport {
 public:
  /// Loads the plugin from the program's own folder and initialises MPI; std::runtime_error
  /// naming the plugin file when it is missing or MPI cannot start.
  MpiTransport();
  ~MpiTransport();  ///< finalises MPI
  MpiTransport(const MpiTransport&) = delete;
  MpiTransport& operator=(const MpiTransport&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  void send(int destination, int tag, const std::string& bytes) const;
  /// The next waiting message, nullopt when none has arrived (never blocks).
  std::optional<MpiMessage> poll() const;
  /// Ends every rank at once (a rank that cannot go on; mpirun reports `code`).
  [[noreturn]] void abort(int code) const;

 private:
  struct Plugin;
  std::unique_ptr<Plugin> plugin_;
  int rank_ = 0, size_ = 1;
};

}  // namespace twill
