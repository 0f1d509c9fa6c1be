"""Command line: typer commands that parse, call `stratcli.api` and render with rich."""

from .app import app as app
