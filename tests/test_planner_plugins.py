"""Planners of one's own on the command line: a scenario file names them, and the modules
that define them are imported from STRATPLAN_PLANNERS (or an installed package's entry points,
group stratplan.planners). A new user's `method = "lsq"` was refused with no way to say where
the planner lives."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from conftest import ROOT

MODULE = """
from stratcli.planners import LegPlanner, NewtonPlanner


class Lsq(LegPlanner):
    method = "lsq-plugin"

    def __init__(self, **overrides):
        self.inner = NewtonPlanner(**overrides)

    def plan(self, problem):
        return self.inner.plan(problem)

    def missing_coefficients(self, problem):
        return self.inner.missing_coefficients(problem)
"""


def _run(tmp_path, *args, modules=""):
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{ROOT}", STRATPLAN_PLANNERS=modules)
    return subprocess.run(
        [sys.executable, "-m", "stratcli", *args], env=env, capture_output=True, text=True,
        cwd=tmp_path, timeout=120,
    )  # fmt: skip


def test_a_scenario_names_a_planner_whose_module_the_variable_names(tmp_path):
    (tmp_path / "myplanners.py").write_text(MODULE)
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    text = text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "lsq-plugin"')
    (tmp_path / "mine.toml").write_text(text)
    refused = _run(tmp_path, "check", "mine.toml")
    assert refused.returncode == 2
    assert refused.stderr.strip() == (
        "error: mine.toml: legs[1].method: must be 'lie' or 'newton' (got 'lsq-plugin'); a "
        "planner of your own: import its module first, or name the module in "
        "STRATPLAN_PLANNERS or under the entry points stratplan.planners"
    )
    broken = _run(tmp_path, "check", "mine.toml", modules="nosuchmodule")
    assert broken.returncode == 2
    assert "error: mine.toml: STRATPLAN_PLANNERS: cannot import 'nosuchmodule' (" in broken.stderr
    planned = _run(tmp_path, "plan", "mine.toml", "--json", "-q", modules="myplanners")
    assert planned.returncode == 0, planned.stderr
    doc = json.loads(planned.stdout)
    assert [leg["method"] for leg in doc["legs"]] == ["newton", "lsq-plugin"]
    assert doc["status"] == "ok"


RAISER = """
from stratcli.planners import LegPlanner, NewtonPlanner


class Raiser(LegPlanner):
    method = "raiser-plugin"

    def plan(self, problem):
        raise RuntimeError("my bug")

    def missing_coefficients(self, problem):
        return NewtonPlanner().missing_coefficients(problem)
"""


def test_a_broken_planner_module_or_a_bug_in_one_is_named_exit_2(tmp_path):
    """A bug in one's own planner ended `plan` with ~80 lines of traceback (stratplan's
    frames) and exit 1, the code of a leg that did not converge; a module that failed to
    import was skipped silently where another module supplied the method."""
    (tmp_path / "myplanners.py").write_text(MODULE)
    (tmp_path / "raising.py").write_text(RAISER)
    (tmp_path / "broken.py").write_text('raise ImportError("boom")\n')
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    (tmp_path / "mine.toml").write_text(
        text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "lsq-plugin"')
    )
    (tmp_path / "bug.toml").write_text(
        text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "raiser-plugin"')
    )
    both = _run(tmp_path, "check", "mine.toml", modules="broken,myplanners")
    assert both.returncode == 2
    assert both.stderr.strip() == (
        "error: mine.toml: STRATPLAN_PLANNERS: cannot import 'broken' (ImportError: boom)"
    )
    bug = _run(tmp_path, "plan", "bug.toml", "-q", modules="raising")
    assert bug.returncode == 2
    lines = bug.stderr.strip().splitlines()
    assert lines[0] == "Traceback (most recent call last):" and "raising.py" in lines[1]
    assert not any("stratcli" in line for line in lines[:-1])  # its own frames only
    assert lines[-1] == (
        "error: RuntimeError: my bug (raised by leg planner 'raiser-plugin' (Raiser.plan) "
        "planning leg 2 on S1; the traceback above is its)"
    )


def test_an_installed_packages_broken_entry_point_does_not_refuse_anothers_planner(tmp_path):
    """One installed package's entry point that failed to import refused every scenario
    naming a planner another entry point supplied; it is named only where a leg's method is
    still unknown (a module of STRATPLAN_PLANNERS, named by the user, is named always)."""
    (tmp_path / "myplanners.py").write_text(MODULE)
    (tmp_path / "broken.py").write_text('raise ImportError("needs casadi")\n')
    info = tmp_path / "eplan-0.0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: eplan\nVersion: 0.0.1\n")
    points = "[stratplan.planners]\nlsq = myplanners\nbroken = broken\n"
    (info / "entry_points.txt").write_text(points)
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    (tmp_path / "mine.toml").write_text(
        text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "lsq-plugin"')
    )
    (tmp_path / "other.toml").write_text(
        text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "nosuch-plugin"')
    )
    found = _run(tmp_path, "check", "mine.toml")
    assert found.returncode == 0, found.stderr
    unknown = _run(tmp_path, "check", "other.toml")
    assert unknown.returncode == 2
    assert "entry point 'broken' of stratplan.planners: cannot load 'broken' (ImportError: " in (
        unknown.stderr
    )


def test_a_module_in_the_current_folder_gets_the_path_it_needs(tmp_path):
    """The README's `STRATPLAN_PLANNERS=myplanners stratplan plan mine.toml` with the module
    beside the scenario: "No module named 'myplanners'" and no hint (`python -m` looks in the
    current folder, the stratplan command does not)."""
    (tmp_path / "myplanners.py").write_text(MODULE)
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    (tmp_path / "mine.toml").write_text(
        text.replace('stratum = "S1"', 'stratum = "S1"\nmethod = "lsq-plugin"')
    )
    code = "import sys; sys.path.remove(''); from stratcli.__main__ import main; main()"
    env = dict(os.environ, PYTHONPATH=str(ROOT), STRATPLAN_PLANNERS="myplanners")
    done = subprocess.run(
        [sys.executable, "-c", code, "check", "mine.toml"], env=env, capture_output=True,
        text=True, cwd=tmp_path, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.splitlines()[0].endswith(
        "myplanners is in the current folder, which the stratplan command does not search: "
        "PYTHONPATH=. STRATPLAN_PLANNERS=myplanners stratplan ..."
    )
