#!/bin/sh
# Fill the on-disk caches of the numba kernels (dolfinx_mortar/kernels/__pycache__, or
# NUMBA_CACHE_DIR where it is set: scripts/test.sh sets the suite's own, at NUMBA_OPT=1) and
# of FFCx (~/.cache/fenics) with two tiny benchmark runs side by side: segment
# integration (about 80 s on this project's 2-core machine, mostly compiling the clipping
# kernels) and element integration with friction (about 40 s; the segment run then loads the kernels they
# share from the cache). Without it, each process that first needs a kernel compiles it:
# both pytest-xdist workers of scripts/test.sh at once (about 110 s each), and every
# `docker run` of an image built without this step (29 s instead of 4 s for the default
# Hertz demo on 2 ranks). A failed run prints the tail of its log and the script goes on
# (exit status 0): what it did not compile is compiled on first use.
# Session 59 (fresh numba cache, warm FFCx cache, 2-core machine nearly idle): the
# segment run 78 s, the element run 58 s; they leave 10 signatures to the serial test
# pass (slip_point_terms, force_geometric_blocks, slip_motion_blocks, facet_mass,
# paired_fraction, projection_derivative and the kernels they call, inside, gap_only,
# for the non-default friction options and gap tests), compiled once, by the worker that
# runs tests/test_friction.py and test_kernels_gap.py (13 s there; the six tests that
# need them: 14.6 s cold, 3.9 s warm); the other worker, the CLI's subprocesses and the
# MPI passes load them. A third warm-up job could save at most those ~11 s of one worker,
# less than the pass's run-to-run spread: not added.
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd -P)  # -P: the path pip records
. "$REPO/scripts/env.sh"
cd "$REPO"
warm=$(mktemp -d)
echo "== warm_cache.sh: compiling the numba kernels (two processes)"
$PY -m dolfinx_mortar bench hertz2d --tiny --levels 1 --integration segment \
    --out "$warm/segment" > "$warm/segment.log" 2>&1 &
segment_pid=$!
$PY -m dolfinx_mortar bench cattaneo2d --tiny --levels 1 --integration element \
    --out "$warm/element" > "$warm/element.log" 2>&1 || tail -n 20 "$warm/element.log"
wait $segment_pid || tail -n 20 "$warm/segment.log"
rm -rf "$warm"
