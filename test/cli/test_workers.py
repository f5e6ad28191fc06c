"""``diagnose --jobs 2`` and ``--scheduler`` give the serial result (issue 14 §3): real worker
processes, a real dask LocalCluster (two worker processes on 127.0.0.1, no dashboard), real files.

diagnosis.json of every way of running must equal the serial one to 1e-9; a corrupt file among
good ones, read in a worker, must be one ``ERROR:`` line naming it, with nothing written.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from cli_runs import listing, run_cli, the_error
from simulated_files import assert_json_close, simulated, write_states


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Path]]:
    folder = tmp_path_factory.mktemp("workers")
    train = [write_states(folder / f"train{k}.mcap", simulated(8.0, 10 + k)) for k in range(3)]
    test = [write_states(folder / f"test{k}.mcap", simulated(5.0, 20 + k)) for k in range(2)]
    return {"train": train, "test": test}


@pytest.fixture(scope="module")
def serial(files, tmp_path_factory: pytest.TempPathFactory) -> dict:
    return _diagnosis(files, tmp_path_factory.mktemp("serial") / "out", "--jobs", "1")


def _diagnosis(files: dict[str, list[Path]], out: Path, *options: str) -> dict:
    result = run_cli("diagnose", "--train", *files["train"], "--test", *files["test"], "--out", out, *options)
    assert result.returncode == 0, result.stderr
    return json.loads((out / "diagnosis.json").read_text())


def test_worker_processes_give_the_serial_result(files, serial, tmp_path: Path) -> None:
    assert_json_close(_diagnosis(files, tmp_path / "out", "--jobs", "2"), serial)


def test_a_dask_cluster_gives_the_serial_result(files, serial, tmp_path: Path) -> None:
    from dask.distributed import Client, LocalCluster

    # dashboard_address=None still serves HTTP on 8787 (dask/distributed#7207): a free port on 127.0.0.1 instead;
    # the workers' scratch in tmp_path, not $TMPDIR/dask-scratch-space
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0", local_directory=str(tmp_path / "dask")
    ) as cluster, Client(cluster) as client:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        assert len(client.scheduler_info()["workers"]) == 2
        assert all(w.startswith("tcp://127.0.0.1:") for w in client.scheduler_info()["workers"])
        assert_json_close(_diagnosis(files, tmp_path / "out", "--scheduler", address), serial)
        # The workers ran the per-file work (they hold its modules) and never imported rclpy.
        seen = client.run(lambda: ("baxter_dynamics_ros.diagnosis.passes" in sys.modules, "rclpy" in sys.modules))
        assert not any(rclpy for _, rclpy in seen.values())
        assert any(passes for passes, _ in seen.values())


def test_a_local_cluster_of_the_command_gives_the_serial_result(files, serial, tmp_path: Path) -> None:
    assert_json_close(_diagnosis(files, tmp_path / "out", "--scheduler", "local", "--jobs", "2"), serial)


def test_a_corrupt_file_in_a_worker_is_one_error_and_nothing_written(files, tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 8)
    out = tmp_path / "out"
    line = the_error(run_cli("diagnose", "--train", *files["train"][:2], bad, "--test", *files["test"], "--out", out, "--jobs", "2"))
    assert str(bad) in line
    assert listing(tmp_path) == ["bad.mcap"]


def test_an_unreachable_scheduler_is_one_error(files, tmp_path: Path) -> None:
    import socket

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "out"
    line = the_error(run_cli("diagnose", "--train", *files["train"], "--test", *files["test"], "--out", out, "--scheduler", f"tcp://127.0.0.1:{port}"))
    assert f"cannot reach a dask scheduler at tcp://127.0.0.1:{port} within 5 s" in line
    assert listing(tmp_path) == []
