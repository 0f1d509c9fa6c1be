"""The one-way layers of README "Layout" and ARCHITECTURE.md, read from the source.

Every `import` and `from ... import` of a stratcli module is collected with `ast`, also those
inside functions (the lazy imports kept for start-up speed) and under `TYPE_CHECKING`: a lazy
import is still a dependency, it only runs later. No module is imported here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "stratcli"

# The layers above the engine, by module name prefix. Everything else in the package (models,
# planners, numerics, sequences, settings, results, errors, ...) is the engine.
SCENARIO = (
    "stratcli.scenario",
    "stratcli.scenario_checks",
    "stratcli.scenario_hints",
    "stratcli.scenario_keys",
    "stratcli.scenario_legs",
    "stratcli.schema_problems",
    "stratcli.task",
    "stratcli.tomlread",
)  # (tomlwrite, a standard-library TOML writer of plain dicts, is a leaf the engine may use:
# `time_scaled` writes a plan's new planner.time_scale into its scenario text)
RECORDS = ("stratcli.records",)
SWEEP = ("stratcli.sweep",)
API = ("stratcli.api", "stratcli.regress")
CLI = ("stratcli.cli", "stratcli.__main__", "stratcli.lean_imports")
UPPER = SCENARIO + RECORDS + SWEEP + API + CLI

# What each layer may not import (README "Layout": the engine imports nothing from the
# scenario schema, the records, the API or the CLI; the API calls the engine and the records;
# the CLI only parses, calls the API and renders).
FORBIDDEN = {
    "engine": UPPER,
    "scenario": RECORDS + SWEEP + API + CLI,
    "records": SWEEP + API + CLI,
    "sweep": API + CLI,
    "api": CLI,
}

# Known violations, each with its reason. Strict: a fix makes this set shrink.
KNOWN = {
    # api.sweeps -> sweep.run -> sweep.worker -> api (lazily, in the worker): a cycle. The
    # worker runs the use cases; moving it into api/ needs the executors to take it as an
    # argument (their initialiser preloads it).
    ("stratcli.sweep.worker", "stratcli.api"),
}


def _name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _public() -> dict[str, str]:
    """stratcli's `_PUBLIC`, read from its source: each name it re-exports, and its module."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "_PUBLIC":
            return ast.literal_eval(node.value)
    raise AssertionError("stratcli/__init__.py has no _PUBLIC")


_PUBLIC = _public()


def _within(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _layer(name: str) -> str:
    for layer, prefixes in (
        ("cli", CLI),
        ("api", API),
        ("sweep", SWEEP),
        ("records", RECORDS),
        ("scenario", SCENARIO),
    ):
        if _within(name, prefixes):
            return layer
    return "package" if name == "stratcli" else "engine"


def _imports(name: str) -> set[tuple[str, int]]:
    """(imported stratcli module or package, line) of every import in module `name`."""
    path = MODULES[name]
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    return _imports_in(path.read_text(encoding="utf-8"), package)


def _imports_in(text: str, package: list[str]) -> set[tuple[str, int]]:
    found = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            found |= {(a.name, node.lineno) for a in node.names if a.name.startswith("stratcli")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = [*package[: len(package) - node.level + 1], node.module or ""]
                module = ".".join(p for p in base if p)
            elif (node.module or "").startswith("stratcli"):
                module = node.module
            else:
                continue
            for alias in node.names:  # `from . import api`: the submodule itself
                sub = f"{module}.{alias.name}"
                if sub not in MODULES and module == "stratcli" and alias.name in _PUBLIC:
                    sub = f"stratcli.{_PUBLIC[alias.name]}"  # `from .. import plan`: re-exported
                found.add((sub if sub in MODULES or module == "stratcli" else module, node.lineno))
        elif isinstance(node, ast.Call) and _called(node) == "import_module" and node.args:
            first = node.args[0]  # importlib.import_module("stratcli.records.rundir")
            if isinstance(first, ast.Constant) and str(first.value).startswith("stratcli"):
                found.add((first.value, node.lineno))
    return found


def _called(node: ast.Call) -> str:
    func = node.func
    return func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")


def _violations() -> dict[tuple[str, str], list[str]]:
    found: dict[tuple[str, str], list[str]] = {}
    for name in MODULES:
        forbidden = FORBIDDEN.get(_layer(name), ())
        for target, line in sorted(_imports(name)):
            if _within(target, forbidden):
                where = f"{MODULES[name].relative_to(PACKAGE.parent)}:{line} imports {target}"
                found.setdefault((name, target), []).append(where)
    return found


def test_the_reader_finds_the_imports_it_must():
    """The collector sees relative, lazy and package-level imports (or the test is blind)."""
    planning = {t for t, _ in _imports("stratcli.api.planning")}
    assert {"stratcli.scenario", "stratcli.objectives", "stratcli.records.manifest"} <= planning
    commands = {t for t, _ in _imports("stratcli.cli.commands")}
    assert "stratcli.api" in commands  # `from .. import api`, inside each command
    assert _layer("stratcli.planners.newton") == "engine"
    hidden = (  # a re-exported name and importlib: each an import of the module it reaches
        "from .. import plan\nfrom stratcli import write_record\n"
        "import importlib\nimportlib.import_module('stratcli.records.rundir')\n"
    )
    seen = {t for t, _ in _imports_in(hidden, ["stratcli", "planners"])}
    assert {"stratcli.api", "stratcli.records.rundir"} <= seen
    assert _layer("stratcli.records.rundir") == "records"


def test_layers_import_only_downward():
    found = _violations()
    new = {key: lines for key, lines in found.items() if key not in KNOWN}
    assert not new, "upward imports:\n" + "\n".join(line for v in new.values() for line in v)


@pytest.mark.parametrize("known", sorted(KNOWN))
def test_each_known_violation_is_still_there(known):
    assert known in _violations(), f"{known} is gone: remove it from KNOWN"
