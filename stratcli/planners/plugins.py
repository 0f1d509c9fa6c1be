"""Planners of one's own found by name: the modules a user names in `STRATPLAN_PLANNERS`, and
installed packages' entry points (group `stratplan.planners`), imported when a scenario's leg
names a method stratplan does not know (defining a `LegPlanner` registers it)."""

from __future__ import annotations

__all__ = ["ENTRY_POINTS", "PLUGINS", "load_plugins"]

PLUGINS = "STRATPLAN_PLANNERS"  # modules to import for planners of one's own (comma-separated)
ENTRY_POINTS = "stratplan.planners"  # the entry-point group of installed packages' planners
_loaded: list = []  # problems of the one loading (`load_plugins`), once done


def load_plugins() -> list[tuple[str, str]]:
    """Import the modules of planners of one's own, once: those named in the environment
    variable `STRATPLAN_PLANNERS` (comma-separated, on the path) and the entry points of the
    group `stratplan.planners` (an installed package's). Defining a `LegPlanner` registers
    it; so a scenario file names it on the command line. Returns a problem per module that
    could not be imported, (where, what), every time: the scenario's check reports them."""
    if _loaded:
        return _loaded[1:]
    import importlib
    import os
    from importlib.metadata import entry_points
    from pathlib import Path

    problems: list = [None]  # (a first entry marks the loading done)
    for module in filter(None, (m.strip() for m in os.environ.get(PLUGINS, "").split(","))):
        try:
            importlib.import_module(module)
        except Exception as exc:  # a user's module: whatever it raises, said in one line
            what = f"cannot import {module!r} ({type(exc).__name__}: {exc})"
            top = module.split(".")[0]
            here = Path(f"{top}.py").is_file() or Path(top, "__init__.py").is_file()
            if isinstance(exc, ModuleNotFoundError) and exc.name == top and here:
                what += (  # (`python -m` looks there, the stratplan command does not)
                    f"; {top} is in the current folder, which the stratplan command does not "
                    f"search: PYTHONPATH=. {PLUGINS}={module} stratplan ..."
                )
            problems.append((PLUGINS, what))
    for point in entry_points(group=ENTRY_POINTS):
        try:
            point.load()
        except Exception as exc:
            what = f"cannot load {point.value!r} ({type(exc).__name__}: {exc})"
            problems.append((f"entry point {point.name!r} of {ENTRY_POINTS}", what))
    _loaded[:] = problems
    return problems[1:]
