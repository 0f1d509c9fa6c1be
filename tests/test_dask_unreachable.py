"""A `--dask` scheduler that cannot be reached: one `error:` line at once (exit 2), not after
Client's 20 s of retries, and no progress shown for work that never started."""

from __future__ import annotations

import socket

import pytest
from sweep_files import AUTO, GRID, write
from typer.testing import CliRunner

import stratcli
from stratcli.cli import app
from stratcli.errors import InputError

pytest.importorskip("distributed")
runner = CliRunner()


@pytest.fixture
def closed_port():
    """A local TCP port that refuses connections: bound, never listening (no one else can
    take it while the test runs)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        yield sock.getsockname()[1]


def test_compare_sequences_on_a_refused_address_is_one_line(tmp_path, closed_port):
    address = f"tcp://127.0.0.1:{closed_port}"
    result = runner.invoke(
        app, ["compare-sequences", str(AUTO), "--dask", address, "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [
        f"error: --dask {address}: cannot reach the scheduler "
        f"(connection refused at 127.0.0.1:{closed_port})"
    ]


def test_sweep_on_a_refused_address_is_one_line_and_writes_nothing(tmp_path, closed_port):
    address = f"127.0.0.1:{closed_port}"  # no scheme: Dask's default, tcp
    out = tmp_path / "o"
    result = runner.invoke(
        app, ["sweep", str(write(tmp_path, GRID)), "--dask", address, "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [
        f"error: --dask {address}: cannot reach the scheduler "
        f"(connection refused at 127.0.0.1:{closed_port})"
    ]
    assert not out.exists()


def test_an_unknown_host_is_named(tmp_path):
    address = "tcp://scheduler.invalid:8786"  # .invalid never resolves (RFC 6761)
    with pytest.raises(InputError, match=r"unknown host 'scheduler.invalid'"):
        stratcli.run_sweep(write(tmp_path, GRID), tmp_path / "o", dask=address)


def test_no_progress_is_reported_before_the_cluster_answers(closed_port):
    calls = []
    with pytest.raises(InputError, match="connection refused"):
        stratcli.compare_sequences(
            AUTO, dask=f"tcp://127.0.0.1:{closed_port}", progress=lambda *a: calls.append(a)
        )
    assert calls == []


@pytest.mark.parametrize(
    "address, port",
    [("localhost:-1", "-1"), ("tcp://localhost:70000", "70000"), ("localhost:abc", "abc")],
)
def test_an_invalid_port_is_called_so_not_an_unknown_host(tmp_path, address, port):
    out = tmp_path / "o"
    result = runner.invoke(
        app, ["sweep", str(write(tmp_path, GRID)), "--dask", address, "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [
        f"error: --dask {address}: invalid port '{port}' (a number from 0 to 65535)"
    ]  # verbatim: `:-1` is no emoji
    assert not out.exists()


def test_an_inproc_address_is_refused_in_words(tmp_path):
    """Python reads the argument it passed (`dask=`), the command line its flag."""
    why = (
        "an inproc:// address is usable only inside the process that made it; give the "
        "scheduler's tcp:// address (host:port) or its scheduler file"
    )
    with pytest.raises(InputError) as info:
        stratcli.run_sweep(write(tmp_path, GRID), tmp_path / "o", dask="inproc://x")
    assert str(info.value) == f"dask='inproc://x': {why}"
    result = runner.invoke(
        app, ["sweep", str(write(tmp_path, GRID)), "--dask", "inproc://x", "--out", str(tmp_path)]
    )
    assert result.exit_code == 2 and result.stderr == f"error: --dask inproc://x: {why}\n"


def test_python_callers_read_dask_not_the_flag(tmp_path, closed_port):
    address = f"tcp://127.0.0.1:{closed_port}"
    expected = f"dask={address!r}: cannot reach the scheduler (connection refused at "
    with pytest.raises(InputError) as info:
        stratcli.compare_sequences(AUTO, dask=address)
    assert str(info.value).startswith(expected)
    with pytest.raises(InputError) as info:
        stratcli.run_sweep(write(tmp_path, GRID), tmp_path / "o", dask=address)
    assert str(info.value).startswith(expected) and "--dask" not in str(info.value)
