# Sourced by the scripts: Open MPI as root in containers, no oversubscription errors,
# one thread per rank (the BLAS in MUMPS), and the Debian interpreter.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
export PY=/usr/bin/python3
