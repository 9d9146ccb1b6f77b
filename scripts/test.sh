#!/bin/sh
# Command 2 of the README (and the only thing .ci/run does): install what is missing,
# then lint, then the whole test suite serially and the MPI tests on 2 and 3 ranks.
# pytest's exit status 5 ("no tests collected") is a failure here.
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd)
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

# The numba kernels compile on first use into their on-disk cache
# (dolfinx_mortar/kernels/__pycache__, empty in a fresh clone). Left to the tests, both
# pytest-xdist workers compile the same kernels at once, about 110 s each. Two tiny
# benchmark runs that need different kernels fill the cache first, side by side: segment
# integration (its clipping kernels take 70 s) and element integration with friction
# (40 s; the segment run then loads the kernels they share from the cache). A failed
# warm-up only costs time: the tests compile what is missing and report the failure.
warm=$(mktemp -d)
echo "== numba warm-up (two processes)"
$PY -m dolfinx_mortar bench hertz2d --tiny --levels 1 --integration segment \
    --out "$warm/segment" > "$warm/segment.log" 2>&1 &
segment_pid=$!
$PY -m dolfinx_mortar bench cattaneo2d --tiny --levels 1 --integration element \
    --out "$warm/element" > "$warm/element.log" 2>&1 || tail -n 20 "$warm/element.log"
wait $segment_pid || tail -n 20 "$warm/segment.log"
rm -rf "$warm"

# Tests marked mpi2 (long 3D demos) run on 2 ranks only: serially they would repeat the
# 2-rank run's assertions, and 3 ranks on the 2 cores would add minutes to the 15-minute
# budget.
# The serial tests run in one process per core (pytest-xdist), a test file per process at
# a time (--dist loadfile: the module fixtures that run demos are made once); the 10
# slowest are listed.
run_pytest "pytest -m 'not mpi2' (serial, -n auto)" $PY -m pytest -q -p no:cacheprovider \
    -n auto --dist loadfile --durations=10 -m "not mpi2" tests
for n in 2 3; do
    marks="mpi"
    if [ "$n" -eq 2 ]; then marks="mpi or mpi2"; fi
    run_pytest "pytest -m '$marks' (mpirun -n $n)" \
        timeout 1500 mpirun -n $n $PY -m mpi4py -m pytest -q -p no:cacheprovider -m "$marks" tests
done
echo "test.sh: all passed"
