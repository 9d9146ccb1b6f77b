#!/bin/sh
# Install whatever is missing for dolfinx_mortar on Debian bookworm (run as root).
# Idempotent: when everything is present it only checks, in about a second.
#   - Debian packages of the stack (the project's design notes): dolfinx 0.5.2, PETSc, MPI, gmsh, numba, ...,
#     and pytest-xdist (the serial tests run on every core: scripts/test.sh)
#   - Debian's OpenBLAS (serial build): it replaces the reference BLAS behind MUMPS and
#     numpy through Debian's alternatives; MUMPS factorizes 2.6 times faster with it
#     (peers problem A, level 3, 36736 dofs: 0.26 s -> 0.10 s a factorization)
#   - ruff (not packaged in bookworm) from PyPI, pinned
#   - this checkout, installed in editable mode for Debian's /usr/bin/python3
# numpy, petsc4py, mpi4py, numba and the FEniCS parts are NEVER taken from PyPI.
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd -P)  # -P: the path pip records
PY=/usr/bin/python3
RUFF_VERSION=0.17.6
PKGS="python3-dolfinx-real python3-petsc4py python3-mpi4py python3-gmsh python3-numba
python3-scipy python3-matplotlib python3-pytest python3-pytest-xdist python3-pip python3-setuptools python3-wheel
openmpi-bin libopenblas0-serial"

missing=""
for p in $PKGS; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $p"
    fi
done
if [ -n "$missing" ]; then
    echo "install.sh: installing Debian packages:$missing"
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $missing
fi

dolfinx=$(dpkg-query -W -f='${Version}' python3-dolfinx-real)
case "$dolfinx" in
    1:0.5.*) ;;
    *) echo "install.sh: error: dolfinx_mortar needs dolfinx 0.5 (Debian bookworm's python3-dolfinx-real); found $dolfinx" >&2
       exit 1 ;;
esac

# ruff is needed by scripts/test.sh only: without PyPI the demo still runs (test.sh then
# fails at its lint step, naming ruff)
if [ "$($PY -m ruff --version 2>/dev/null)" != "ruff $RUFF_VERSION" ]; then
    echo "install.sh: installing ruff $RUFF_VERSION from PyPI"
    $PY -m pip install --break-system-packages --no-deps -q "ruff==$RUFF_VERSION" ||
        echo "install.sh: warning: could not install ruff $RUFF_VERSION (scripts/test.sh needs it)" >&2
fi

# Editable install of this very checkout (re-done when another checkout was installed).
where=$(cd /tmp && $PY -c "import dolfinx_mortar, os; print(os.path.dirname(os.path.dirname(os.path.abspath(dolfinx_mortar.__file__))))" 2>/dev/null || true)
if [ "$where" != "$REPO" ] || ! command -v dolfinx-mortar >/dev/null 2>&1; then
    echo "install.sh: installing dolfinx_mortar from $REPO (editable)"
    $PY -m pip install --break-system-packages --no-deps --no-build-isolation -q -e "$REPO"
fi
