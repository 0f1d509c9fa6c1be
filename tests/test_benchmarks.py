"""The benchmark scripts the README's tables come from still run against the library.

They are not part of the package, so nothing else notices when the library's signatures or
messages move under them (two did: bench_peer's spy on the energy search, and the random
constrained tasks' reading of the loader's messages). Each script is imported (its argument
parser and helpers; nothing is timed), and the pieces that reach into the library are run on
something small. CasADi is not needed: only the stratplan side is exercised.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

import stratcli

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.stem for p in BENCHMARKS.glob("bench_*.py"))


@pytest.fixture(autouse=True)
def _benchmarks_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCHMARKS))


@pytest.mark.parametrize("name", SCRIPTS)
def test_every_benchmark_script_imports_and_parses_its_defaults(name, monkeypatch):
    module = importlib.import_module(name)
    assert callable(getattr(module, "main", None)), f"{name} has no main()"
    parsers = []
    cls = module.argparse.ArgumentParser
    for method in ("parse_args", "parse_intermixed_args"):
        real = getattr(cls, method)

        def parse_only(self, args=None, namespace=None, real=real):
            parsers.append(real(self, args, namespace))
            raise SystemExit(0)  # stop before anything is planned or timed

        monkeypatch.setattr(cls, method, parse_only)
    positional = [str(BENCHMARKS.parent)] if name == "bench_against" else []
    monkeypatch.setattr(sys, "argv", [name, *positional])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code in (0, None) and parsers


@pytest.mark.parametrize(
    ("name", "argv"),
    [("bench_against", ["/nonexistent"]), ("bench_constraints", ["--against", "/nonexistent"])],
)
def test_a_directory_that_is_no_checkout_is_refused(name, argv, monkeypatch, capsys):
    """Given a directory without stratcli/, the child processes would import this checkout's
    package and compare it with itself: refused with one line, exit 2."""
    module = importlib.import_module(name)
    monkeypatch.setattr(sys, "argv", [name, *argv])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 2
    assert "/nonexistent is not a checkout of stratplan" in capsys.readouterr().err


def test_bench_peer_captures_the_energy_searchs_starts():
    """bench_peer hands IPOPT the starts stratplan's energy search was given: its spy must take
    the search's arguments as the library passes them (it raised TypeError when a keyword
    was added)."""
    bench_peer = importlib.import_module("bench_peer")
    task = stratcli.load_scenario(BENCHMARKS.parent / "scenarios" / "sim2.toml")
    plan, seconds, captured = bench_peer.stratplan_run(task, repeats=1)
    assert plan.ok and seconds > 0
    assert len(captured.nominal) == len(task.legs) == len(captured.targets)
    assert captured.seeds and all(np.all(np.isfinite(lam)) for _, lam in captured.seeds)


def test_random_constrained_tasks_are_redrawn_for_every_configuration_problem():
    """A drawn task whose goal only comes within the clearance of the robot itself (the
    loader's wording since it tells that apart from a collision) is redrawn as a
    self-collision, not raised (bench_random --constraints stopped on it)."""
    from bench_random import make_task
    from random_constraints import pre_violation

    task = make_task(2084654370)  # its goal: link 2 is 0.0155 from the base (clearance 0.05)
    with pytest.raises(stratcli.InputError, match="comes within the clearance of itself"):
        stratcli.load_scenario({**task, "constraints": {"self_collision": True, "clearance": 0.05}})
    assert pre_violation(task) == "self-collision"


def test_random_constrained_tasks_outside_a_joint_limit_are_redrawn():
    """A drawn task whose goal is outside ±2.5 rad is redrawn as a joint-limit problem: the
    loader calls them "its limits" since a start or via outside one says where the limit
    comes from (bench_random --constraints stopped on the first such task, 579362556)."""
    from bench_random import make_task
    from random_constraints import pre_violation

    assert pre_violation(make_task(579362556)) == "joint limits and self-collision"


def test_the_phases_of_a_constrained_plan_add_up_to_less_than_the_plan(capsys):
    """`bench_constraints.py --phases`: each phase of Sim 4 C's constrained plan has steps and
    CPU time, together less than the whole plan's (which also plans the free plan), and the
    methods it wrapped are unwrapped afterwards."""
    module = importlib.import_module("bench_constraints")
    owners = module.owners_of_phases()
    before = {(o, m): getattr(owners[o], m) for o, m in module.PHASES.values()}
    module.phases(["sim4_task_c_constrained"], 1)
    assert all(getattr(owners[o], m) is f for (o, m), f in before.items())
    row = capsys.readouterr().out.splitlines()[-1].split()
    assert row[0] == "sim4_task_c_constrained"
    total, cells = float(row[1]), " ".join(row[2:]).replace("(", " ").replace(")", " ").split()
    times, steps = [float(c) for c in cells[0::2]], [int(c) for c in cells[1::2]]
    assert len(times) == len(module.PHASES) and sum(times) < total
    assert all(n >= 1 for n in steps) and steps[-1] == 1  # one verification
