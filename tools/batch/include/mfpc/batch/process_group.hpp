#pragma once

/// @file
/// The processes one batch is shared between: those of an MPI launch, else this process alone.
/// MPI stays behind this interface: nothing else in MFPC includes its header.

#include <cstdint>
#include <vector>

namespace mfpc {

/// The processes of this run. Started by `mpirun` (Open MPI's or a PMI launcher's environment)
/// in a build with MPI, they are the launch's ranks; otherwise this process alone.
class ProcessGroup {
public:
    /// Joins the MPI launch when there is one (MPI_Init), else makes a group of one.
    /// @throws mfpc::Error when launched by mpirun but built without MPI
    ProcessGroup();
    /// Leaves the launch (MPI_Finalize), or ends it for every rank (MPI_Abort) when destroyed by
    /// an exception, so that no rank waits for one that failed.
    ~ProcessGroup();
    ProcessGroup(const ProcessGroup&) = delete;
    ProcessGroup& operator=(const ProcessGroup&) = delete;

    /// @return this process's rank, 0..size()-1
    int rank() const { return rank_; }
    /// @return how many processes share the run
    int size() const { return size_; }
    /// @return whether the run is an MPI launch
    bool launched() const { return launched_; }
    /// Waits until every process reaches this point.
    void barrier() const;
    /// @param values this process's counts, the same number on every process
    /// @return their sums over the processes, on every process
    std::vector<std::uint64_t> sum(const std::vector<std::uint64_t>& values) const;
    /// @param value this process's value
    /// @return the largest over the processes, on every process
    double max(double value) const;

private:
    int rank_ = 0;
    int size_ = 1;
    bool launched_ = false;
};

}  // namespace mfpc
