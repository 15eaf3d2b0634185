"""Respawn as a launch file's, with a limit: which node comes back, when, and when the cell
stops instead; the cell file's keys checked with the node and key named."""

from __future__ import annotations

import io

import pytest
import yaml

from nodes.cell.launch import load_cell
from nodes.cell.processes import CellRun
from nodes.cell.respawn import Respawn, RespawnBook, respawn_env
from nodes.common.paths import config_path


def test_a_node_that_may_respawn_comes_back_after_its_delay_until_its_limit():
    book = RespawnBook({"executor": Respawn(True, 2.0, 2), "sim": Respawn()})
    assert book.on_exit("executor", -9, 10.0) == (
        "node executor exited (code -9); respawning in 2 s (1 of 2)")
    assert book.due(11.9) == [] and book.due(12.0) == ["executor"] and book.due(12.0) == []
    book.on_exit("executor", 1, 20.0)
    assert book.due(22.0) == ["executor"] and book.fatal is None
    line = book.on_exit("executor", -9, 30.0)
    assert "no respawn left (2 used); stopping the cell" in line
    assert book.fatal == "node executor exited (code -9); respawned 2 time(s) already"
    assert book.due(100.0) == []


def test_a_node_without_respawn_stops_the_cell_only_when_it_fails():
    book = RespawnBook({"sim": Respawn(), "goal": Respawn()})
    assert book.on_exit("goal", 0, 1.0) == "node goal exited (code 0); not respawned"
    assert book.fatal is None
    book.on_exit("sim", -11, 2.0)
    assert book.fatal == "node sim exited (code -11); it does not respawn"


@pytest.mark.parametrize(("spec", "named"), [
    ({"respawn": "yes"}, "respawn must be true or false"),
    ({"respawn": True, "respawn_delay": -1}, "respawn_delay must be a number of seconds"),
    ({"respawn": True, "respawn_delay": float("nan")}, "respawn_delay"),
    ({"respawn": True, "respawn_max": 1.5}, "respawn_max must be a whole number"),
])
def test_a_bad_respawn_key_names_the_node_and_the_key(tmp_path, spec, named):
    cell = tmp_path / "cell.yaml"
    cell.write_text(yaml.safe_dump({"nodes": {"planner": spec}}))
    with pytest.raises(SystemExit, match=f"node 'planner': {named}"):
        load_cell(cell)


def test_the_shipped_cells_respawn_every_densepack_node_but_the_sim():
    for name in ("cell.yaml", "real/cell.yaml"):
        launches, _ = load_cell(config_path(name))
        respawning = {launch.name for launch in launches if launch.respawn.enabled}
        assert respawning == {launch.name for launch in launches} - {"sim"}, name


class FakeProc:
    def __init__(self, code: int | None) -> None:
        self.returncode = code

    def poll(self) -> int | None:
        return self.returncode


def test_a_run_starts_a_crashed_node_again_and_reports_the_one_it_may_not(tmp_path,
                                                                         monkeypatch):
    cell_file = tmp_path / "cell.yaml"
    cell_file.write_text("nodes:\n  planner: {respawn: true, respawn_delay: 0.0, respawn_max: 1}"
                         "\n  sim: {}\n")
    log = io.StringIO()
    run = CellRun(tmp_path / "scene.yaml", log, cell_file=str(cell_file))
    started: list[str] = []
    monkeypatch.setattr(run, "start",
                        lambda name=None, again=False: started.append(name) if again else None)
    run.procs = {"planner": FakeProc(-9), "sim": FakeProc(None)}
    assert run.supervise() is None and started == ["planner"]  # started again: respawn_env
    assert "[cell] node planner exited (code -9); respawning in 0 s (1 of 1)" in log.getvalue()
    run.procs = {"planner": FakeProc(None), "sim": FakeProc(None)}
    run.killed.add("sim")  # killed on purpose (a fault injected): not the book's
    run.procs["sim"] = FakeProc(-9)
    assert run.supervise() is None and started == ["planner"]
    run.procs["planner"] = FakeProc(-9)
    assert run.supervise() == "node planner exited (code -9); respawned 1 time(s) already"


def test_a_node_started_again_talks_udp_only_unless_the_user_chose_a_transport():
    env = respawn_env({"ROS_DOMAIN_ID": "7"})
    assert env["ROS_DOMAIN_ID"] == "7"
    assert env["FASTDDS_BUILTIN_TRANSPORTS"].split("?")[0] == "UDPv4"
    chosen = {"FASTDDS_BUILTIN_TRANSPORTS": "LARGE_DATA"}
    assert respawn_env(chosen) == chosen
