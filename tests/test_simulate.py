"""Re-integration of a plan for its record: bounded work, said so."""

from __future__ import annotations

import numpy as np

import stratcli.simulate as simulate


def test_reintegration_is_bounded_and_says_so(unicycle_plan, monkeypatch):
    _, plan = unicycle_plan
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    assert np.isnan(traj.q).all() and len(traj.notes) == len(plan.legs)
    assert "could not be re-integrated" in traj.notes[0]
    monkeypatch.undo()
    traj = simulate.sample(plan, 50)
    assert np.isfinite(traj.q).all() and traj.notes == ()
