"""The frictional demos, run small, against their exact or analytic solutions.

Like ``test_demos.py``: each demo's ``main(argv)`` runs in-process and returns its
metrics (the same on every rank); the ``mpi`` tests also run under mpirun.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

DEMOS = Path(__file__).resolve().parents[1] / "demos"
sys.path.insert(0, str(DEMOS))

import demo_friction_patch  # noqa: E402


@pytest.mark.mpi
@pytest.mark.parametrize("mode", ["stick", "slide"])
@pytest.mark.parametrize("integration,tol", [("segment", 1e-8), ("element", 0.02)])
def test_friction_patch2d(shared_tmp, mode, integration, tol):
    out = str(shared_tmp / f"fpatch2d-{mode}-{integration}")
    m = demo_friction_patch.main(["--mode", mode, "--integration", integration, "--out", out])
    assert m["p_err"] <= tol, m["p_err"]
    assert m["q_err"] <= tol, m["q_err"]
    assert m["wrong_state"] == 0
    assert m["force_normal_err"] <= 1e-8 and m["force_tangential_err"] <= 1e-8
    assert m["modelled"]["tangential_fields"] is True
    if mode == "stick":
        assert max(m["dissipation"]) <= 1e-10
    else:
        # μ p0 L × slip of each step: the top moves 0.025 per step, the upper block's
        # elastic shear μ p(t)/G · H (G = 50) takes 0.005 in step 1 (p0/2) and no more after
        assert m["dissipation"] == pytest.approx([0.5 * 0.02, 1.0 * 0.02], rel=1e-8)
    assert max(m["newton_iterations"]) <= 25


@pytest.mark.parametrize("mode", ["stick", "slide"])
def test_friction_patch3d(shared_tmp, mode):
    out = str(shared_tmp / f"fpatch3d-{mode}")
    m = demo_friction_patch.main(
        ["--dim", "3", "--mode", mode, "--integration", "segment", "--out", out]
    )
    assert m["p_err"] <= 1e-8, m["p_err"]
    assert m["q_err"] <= 1e-8, m["q_err"]
    assert m["q_cross"] <= 1e-8, m["q_cross"]
    assert m["wrong_state"] == 0
    assert max(m["newton_iterations"]) <= 25
