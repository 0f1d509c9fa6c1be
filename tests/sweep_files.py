"""Small sweep files for the sweep tests: Newton-objective tasks of the paper's Sim 4."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TASK_A = ROOT / "scenarios" / "sim4_task_a.toml"
AUTO = ROOT / "scenarios" / "sim4_auto.toml"


def write(tmp_path: Path, body: str, *, scenario: Path = TASK_A, mode: str = "legs",
          objective: str = "newton", name: str = "small") -> Path:  # fmt: skip
    """A sweep file in `tmp_path` over `scenario` with `body` (its grid, random or tasks)."""
    path = tmp_path / f"{name}.toml"
    path.write_text(
        f'[sweep]\nname = "{name}"\nscenario = "{scenario}"\nmode = "{mode}"\n'
        f'set = {{ "planner.objective" = "{objective}" }}\n\n{body}'
    )
    return path


GRID = """[sweep.grid]
"goal.q1" = { linspace = ["-pi/3", 0, 3] }
"goal.theta" = [-0.2, "-pi/12"]
"""

RANDOM = """[sweep.random]
count = 4
seed = 11
ranges = { "goal.q1" = ["-pi/2", 0], "goal.theta" = [-0.4, 0.0] }
"""


def strip(rows: dict) -> dict:
    """The rows without the columns that depend on the machine and the moment."""
    from stratcli.sweep import TIMING_COLUMNS

    return {k: {c: v for c, v in r.items() if c not in TIMING_COLUMNS} for k, r in rows.items()}
