# Sourced by the scripts: Open MPI as root in containers, no oversubscription errors,
# one thread per rank (the BLAS in MUMPS), and the Debian interpreter.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
export PY=/usr/bin/python3
# In a Docker container Open MPI's shared-memory single copy (CMA, process_vm_readv) is
# often refused ("Read -1, expected N, errno = 1"): use the copy-in/copy-out path there.
if [ -f /.dockerenv ]; then
    export OMPI_MCA_btl_vader_single_copy_mechanism=none
fi
