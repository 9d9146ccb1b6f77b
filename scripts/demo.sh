#!/bin/sh
# Command 1 of the README: install what is missing, then run the main job
# (2D Hertz contact under mpirun -n 2; prints its error against the analytic solution).
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd -P)  # -P: the path pip records
sh "$REPO/scripts/install.sh"
. "$REPO/scripts/env.sh"
cd "$REPO"
exec mpirun -n 2 $PY demos/demo_hertz2d.py "$@"
