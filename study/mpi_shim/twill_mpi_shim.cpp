// The only code of twill that calls MPI (issue #17, docs/studies.md §4): a plugin the program
// loads at run time (study/mpi_transport.cpp) when `twill sweep` is started by mpirun.
//
// Why a plugin and not a link: Debian's Ipopt links MUMPS's sequential build, whose dummy MPI
// exports MPI_Init and friends. Linking Open MPI into the program would bind Ipopt's calls to
// the real MPI (every `twill fit` with Ipopt would start MPI), and linking it after MUMPS
// would bind the sweep's calls to the dummy. Loaded with RTLD_LOCAL | RTLD_DEEPBIND, this
// plugin and Open MPI resolve their MPI symbols among themselves and the rest of the program
// keeps the dummy. Byte messages only; the transport gives them meaning.
#include <mpi.h>

extern "C" {

int twill_mpi_init(int* rank, int* size) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized && MPI_Init(nullptr, nullptr) != MPI_SUCCESS) return 1;
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  if (MPI_Comm_rank(MPI_COMM_WORLD, rank) != MPI_SUCCESS) return 1;
  return MPI_Comm_size(MPI_COMM_WORLD, size) == MPI_SUCCESS ? 0 : 1;
}

int twill_mpi_send(const char* bytes, int count, int destination, int tag) {
  return MPI_Send(bytes, count, MPI_CHAR, destination, tag, MPI_COMM_WORLD) == MPI_SUCCESS ? 0 : 1;
}

// 1 when a message is waiting (its source, tag and size set), 0 when none, -1 on an error.
int twill_mpi_poll(int* source, int* tag, int* count) {
  int waiting = 0;
  MPI_Status status;
  if (MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &waiting, &status) != MPI_SUCCESS) return -1;
  if (!waiting) return 0;
  *source = status.MPI_SOURCE;
  *tag = status.MPI_TAG;
  return MPI_Get_count(&status, MPI_CHAR, count) == MPI_SUCCESS ? 1 : -1;
}

int twill_mpi_receive(char* bytes, int count, int source, int tag) {
  return MPI_Recv(bytes, count, MPI_CHAR, source, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE) == MPI_SUCCESS ? 0 : 1;
}

void twill_mpi_abort(int code) { MPI_Abort(MPI_COMM_WORLD, code); }

int twill_mpi_finalize() { return MPI_Finalize() == MPI_SUCCESS ? 0 : 1; }

}  // extern "C"
