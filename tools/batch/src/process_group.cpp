#include "mfpc/batch/process_group.hpp"

#include <cstdlib>
#include <exception>

#include "mfpc/core/error.hpp"

#ifdef MFPC_HAVE_MPI
// The C API only: Open MPI's deprecated C++ bindings would need their own library.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace mfpc {
namespace {

// mpirun tells its processes who they are through the environment; a process started otherwise
// must not initialise MPI (a singleton launch is slow and needs no peers).
bool launched_by_mpirun()
{
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
        if (std::getenv(name) != nullptr) return true;
    return false;
}

}  // namespace

ProcessGroup::ProcessGroup()
{
    if (!launched_by_mpirun()) return;
#ifdef MFPC_HAVE_MPI
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) MPI_Init(nullptr, nullptr);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    launched_ = true;
#else
    throw Error("batch", "started by mpirun, but this mfpc was built without MPI (install the Debian packages "
                         "libopenmpi-dev and openmpi-bin, as scripts/install-deps.sh does, and rebuild)");
#endif
}

ProcessGroup::~ProcessGroup()
{
#ifdef MFPC_HAVE_MPI
    if (!launched_) return;
    if (std::uncaught_exceptions() > 0) MPI_Abort(MPI_COMM_WORLD, 1);
    MPI_Finalize();
#endif
}

void ProcessGroup::barrier() const
{
#ifdef MFPC_HAVE_MPI
    if (launched_) MPI_Barrier(MPI_COMM_WORLD);
#endif
}

std::vector<std::uint64_t> ProcessGroup::sum(const std::vector<std::uint64_t>& values) const
{
    std::vector<std::uint64_t> sums = values;
#ifdef MFPC_HAVE_MPI
    if (launched_)
        MPI_Allreduce(values.data(), sums.data(), int(values.size()), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
#endif
    return sums;
}

double ProcessGroup::max(double value) const
{
    double largest = value;
#ifdef MFPC_HAVE_MPI
    if (launched_) MPI_Allreduce(&value, &largest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
#endif
    return largest;
}

}  // namespace mfpc
