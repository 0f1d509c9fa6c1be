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


def _refused_sweep(tmp_path, address: str) -> list[str]:
    """`stratplan sweep --dask address`: exit 2, nothing written; its stderr lines."""
    out = tmp_path / "o"
    result = runner.invoke(
        app, ["sweep", str(write(tmp_path, GRID)), "--dask", address, "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert not out.exists()
    return result.stderr.splitlines()


def test_sweep_on_a_refused_address_is_one_line_and_writes_nothing(tmp_path, closed_port):
    address = f"127.0.0.1:{closed_port}"  # no scheme: Dask's default, tcp
    assert _refused_sweep(tmp_path, address) == [
        f"error: --dask {address}: cannot reach the scheduler "
        f"(connection refused at 127.0.0.1:{closed_port})"
    ]


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
    assert _refused_sweep(tmp_path, address) == [
        f"error: --dask {address}: invalid port '{port}' (a number from 0 to 65535)"
    ]  # verbatim: `:-1` is no emoji


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


@pytest.fixture
def listener():
    """A local port that accepts connections and then either says something that is not
    Dask's (an HTTP reply, as a dashboard or web server would) or nothing at all."""
    import threading

    servers = []

    def serve(reply: bytes | None) -> int:
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        server.settimeout(0.2)
        held, stop = [], threading.Event()

        def accept():
            while not stop.is_set():
                try:
                    conn, _ = server.accept()
                except OSError:  # (the timeout, or the socket closed)
                    continue
                held.append(conn)
                if reply is not None:
                    conn.sendall(reply)

        thread = threading.Thread(target=accept, daemon=True)
        thread.start()
        servers.append((server, held, stop, thread))
        return server.getsockname()[1]

    yield serve
    for server, held, stop, thread in servers:
        stop.set()
        thread.join()
        for conn in held:
            conn.close()
        server.close()


def test_a_port_that_answers_but_not_as_dask_is_called_so(tmp_path, listener):
    """(It had come back as numpy's "Unable to allocate 3.07 EiB": Dask's frame header read
    from an HTTP reply.)"""
    port = listener(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
    address = f"tcp://127.0.0.1:{port}"
    assert _refused_sweep(tmp_path, address) == [
        f"error: --dask {address}: it answered, but not as a Dask scheduler (a Dask scheduler "
        "listens on port 8786 by default; 8787 is its dashboard's)"
    ]


def test_a_port_that_never_answers_is_given_up(tmp_path, listener, monkeypatch):
    """A port that accepts and stays silent had kept Client waiting for as long as the other
    end held the connection (79 s, and more): now the connection's time is bounded."""
    from stratcli.sweep import executors

    monkeypatch.setattr(executors, "CONNECT_SECONDS", 1.0)
    address = f"tcp://127.0.0.1:{listener(None)}"
    raised = []

    def sweep():  # on a thread: a wait that does not end fails the test instead of hanging it
        try:
            stratcli.run_sweep(write(tmp_path, GRID), tmp_path / "o", dask=address)
        except InputError as exc:
            raised.append(exc)

    import threading

    thread = threading.Thread(target=sweep, daemon=True)
    thread.start()
    thread.join(60)
    assert not thread.is_alive(), "still waiting for the scheduler after 60 s"
    assert raised, "no InputError"
    said = str(raised[0])
    assert said.startswith(f"dask={address!r}: "), said
    assert "no Dask scheduler answered there within 1 s" in said or "cannot reach" in said
    assert not (tmp_path / "o").exists()


def test_an_empty_address_or_a_folder_is_refused_not_run_here(tmp_path):
    """`--dask "$SCHEDULER"` with the variable unset had planned on local workers without a
    word; a folder had been called a scheduler that "answered, but not as" one."""
    assert _refused_sweep(tmp_path, "") == [
        "error: --dask: empty: give a scheduler's address (tcp://host:8786) or its file"
    ]
    folder = tmp_path / "cluster"
    folder.mkdir()
    assert _refused_sweep(tmp_path, str(folder)) == [
        f"error: --dask {folder}: a folder, not a scheduler's address (tcp://host:8786) or its "
        "JSON file"
    ]
    with pytest.raises(InputError, match=r"^dask: empty"):
        stratcli.run_sweep(write(tmp_path, GRID), tmp_path / "o", dask="")


def test_a_comparison_refused_its_cluster_leaves_no_out_folder(tmp_path, closed_port):
    """(compare-sequences had made --out before connecting, and left it empty.)"""
    out = tmp_path / "runs"
    address = f"tcp://127.0.0.1:{closed_port}"
    result = runner.invoke(
        app, ["compare-sequences", str(AUTO), "--dask", address, "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert not out.exists()
    kept = tmp_path / "kept"  # a folder that was there before stays
    kept.mkdir()
    result = runner.invoke(
        app, ["compare-sequences", str(AUTO), "--dask", address, "--out", str(kept)]
    )
    assert result.exit_code == 2 and kept.is_dir()
