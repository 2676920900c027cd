// Batch work (sweep, robustness) spread over MPI ranks, threads inside each rank.
//
// MPI starts only when the process was launched by an MPI starter (mpirun/mpiexec of OpenMPI,
// or Slurm's srun with PMI/PMIx): its environment says so. A plain `stance` run never
// initialises MPI, so its stderr and exit stay as they are. In a build without MPI
// (STANCE_WITH_MPI=OFF) there is always one rank.
//
// Work items are handed out by rank 0 as ranks free up (a run that falls ends early); the results
// are encoded as text, gathered at rank 0 and decoded there, so rank 0 holds exactly what a single
// process would have computed and writes every output. Results do not depend on the rank or thread
// count.
#pragma once

#include <functional>
#include <string>

namespace stance {

class BatchRanks {
 public:
  // the process's ranks; initialises MPI on first use when launched by an MPI starter
  static BatchRanks& get();

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }

  // job(i) for the indices of [0, n) this rank is handed, on `threads` threads; then encode(i)
  // of every rank's indices is gathered at rank 0, which calls decode(i, text) for the other ranks'
  // (an empty text: that item did not finish). An exception in this rank's jobs is rethrown after
  // the gather; one in another rank's makes every rank throw.
  // every_rank: every rank decodes the others' items (for work whose next step needs all the
  // results on every rank, as a tuner's next generation does)
  void distributed_for(int n, int threads, const std::function<void(int)>& job,
                       const std::function<std::string(int)>& encode,
                       const std::function<void(int, const std::string&)>& decode,
                       bool every_rank = false);

  ~BatchRanks();
  BatchRanks(const BatchRanks&) = delete;
  BatchRanks& operator=(const BatchRanks&) = delete;

 private:
  BatchRanks();
  int rank_ = 0, size_ = 1;
  bool initialised_ = false;  // this process called MPI_Init (and will call MPI_Finalize)
};

// true when the environment shows an MPI starter launched this process
bool launched_by_mpi();

}  // namespace stance
