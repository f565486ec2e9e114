# Sourced by the tests/mpi scripts: how OpenMPI runs here (as root, more ranks than cores, in containers).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none  # containers often forbid the cross-memory attach
export OMPI_MCA_mpi_yield_when_idle=1 OMP_WAIT_POLICY=PASSIVE  # more ranks (and threads) than cores: waiting ones yield
# Sanitizer builds: what OpenMPI keeps allocated at MPI_Finalize is not ours (AddressSanitizer errors still fail).
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
