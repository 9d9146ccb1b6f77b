#!/bin/sh
# Command 2 of the README (and the only thing .ci/run does): install what is missing,
# then lint, then the whole test suite serially and the MPI tests on 2 and 3 ranks.
# pytest's exit status 5 ("no tests collected") is a failure here.
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd -P)  # -P: the path pip records
sh "$REPO/scripts/install.sh"
. "$REPO/scripts/env.sh"
cd "$REPO"

run_pytest() {
    # $1: label, rest: command; fails on any non-zero status, including 5 (no tests).
    # MPI runs sit under `timeout`: a test failing on one rank only would otherwise leave
    # the other ranks waiting in a collective forever.
    label=$1; shift
    echo "== $label"
    set +e
    "$@"
    rc=$?
    set -e
    if [ $rc -eq 5 ]; then echo "test.sh: $label collected no tests" >&2; exit 1; fi
    if [ $rc -ne 0 ]; then echo "test.sh: $label failed (exit $rc)" >&2; exit $rc; fi
}

echo "== ruff"
$PY -m ruff check .
$PY -m ruff format --check .

# The suite's numba kernels: compiled at LLVM optimisation level 1 (numba's default is 3)
# into a cache of the suite's own, .numba-test-cache/ (gitignored); the package's cache
# (dolfinx_mortar/kernels/__pycache__, the demos' and the Docker image's, level 3) is left
# as it is. Level 1 compiles in about 3/4 of the time (the warm-up below 78 -> 57 s on
# the 2-core machine) and the tests run no slower; the numbers are the same bit for bit
# (no kernel asks for fast-math, so LLVM reorders no floating-point operation; checked on
# demo_hertz3d and demo_cattaneo2d's outputs, BENCHMARKS.md section 97). The children that
# the tests start (the CLI under mpirun, the bench scripts) inherit both settings.
export NUMBA_OPT=1 NUMBA_CACHE_DIR="$REPO/.numba-test-cache"

# The numba kernels compile on first use; fill their cache first, in two processes
# (scripts/warm_cache.sh), or both xdist workers below compile the same kernels at once.
sh "$REPO/scripts/warm_cache.sh"

# Tests marked mpi2 (long 3D demos) run on 2 ranks only: serially they would repeat the
# 2-rank run's assertions, and 3 ranks on the 2 cores would add minutes to the 15-minute
# budget. Tests marked mpi_not1 run under mpirun only: their MPI runs make their serial
# run as the reference, with the serial pass's assertions on it.
# The serial tests run in one process per core (pytest-xdist), a test file per process at
# a time (--dist loadfile: the module fixtures that run demos are made once); the 10
# slowest are listed.
# Workers: the CPUs this process may use, capped by a cgroup v2 CPU quota (a container
# limited to 2 CPUs on a large host would otherwise start one worker per host CPU);
# DM_TEST_WORKERS overrides. (nproc obeys OMP_NUM_THREADS, which env.sh sets to 1.)
workers=$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc)
if [ -r /sys/fs/cgroup/cpu.max ]; then
    read -r quota period < /sys/fs/cgroup/cpu.max
    if [ "$quota" != max ] && [ "$(( (quota + period - 1) / period ))" -lt "$workers" ]; then
        workers=$(( (quota + period - 1) / period ))
    fi
fi
workers=${DM_TEST_WORKERS:-$workers}
run_pytest "pytest -m 'not mpi2 and not mpi_not1' (serial, -n $workers)" timeout 2400 \
    $PY -m pytest -q -p no:cacheprovider -n "$workers" --dist loadfile --durations=10 \
    -m "not mpi2 and not mpi_not1" tests
# Under mpirun, tests/conftest.py selects the tests of each size (mpi_marks: on 2 ranks
# -m 'mpi or mpi2', on 3 -m 'mpi and not mpi_not3'), and says which.
for n in 2 3; do
    run_pytest "pytest (mpirun -n $n, tests/conftest.py's mpi_marks)" \
        timeout 1500 mpirun -n $n $PY -m mpi4py -m pytest -q -p no:cacheprovider tests
done
echo "test.sh: all passed"
