"""Command line: typer commands that parse, call `stratcli.api` and render with rich."""

from typing import Any

from .app import app as app


def __getattr__(name: str) -> Any:
    # `load_scenario` is imported on first use, for start-up speed (`stratplan --help` needs
    # no model code); the commands look it up here, so tests can substitute it.
    if name == "load_scenario":
        from ..scenario import load_scenario

        return load_scenario
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
