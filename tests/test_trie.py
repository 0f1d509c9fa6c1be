"""The processes that plan candidate sequences: on any `concurrent.futures.Executor` (a
spawned pool, threads, a Dask cluster) the comparison is the same as with forked workers."""

from __future__ import annotations

import dataclasses
import json
from concurrent.futures import ThreadPoolExecutor

import pytest
from conftest import ROOT

from stratcli.api import compare_sequences
from stratcli.models.presets import preset
from stratcli.models.system import System
from stratcli.records.comparison import without_timings
from stratcli.scenario import load_scenario
from stratcli.sweep import local_executor

AUTO = ROOT / "scenarios" / "sim4_auto.toml"


def _task(objective: str):
    return load_scenario(AUTO).with_changes({"planner": {"objective": objective}})


def _doc(outcome) -> str:
    return json.dumps(without_timings(outcome.document), sort_keys=True)


@pytest.fixture(scope="module")
def forked():
    """Newton: shared prefixes in forked workers (the default path)."""
    return compare_sequences(_task("newton"), jobs=2)


def test_a_spawned_pool_and_threads_give_the_forked_comparison(forked):
    with local_executor(2) as pool:  # workers rebuild the model from its [model] table
        spawned = compare_sequences(_task("newton"), executor=pool)
    with ThreadPoolExecutor(2) as pool:
        threads = compare_sequences(_task("newton"), executor=pool)
    assert _doc(spawned) == _doc(forked) == _doc(threads)
    assert spawned.best.result.total_energy == forked.best.result.total_energy


def test_a_model_made_in_python_needs_forked_workers():
    task = _task("newton")
    one = preset("one-arm")
    task = dataclasses.replace(
        task,
        system=System(
            "made-in-python", one.states, one.inputs, one.fields, one.strata, dict(one.parameters)
        ),
    )  # no [model] table: a worker could not rebuild it
    with ThreadPoolExecutor(1) as pool, pytest.raises(ValueError, match="made in Python"):
        compare_sequences(task, executor=pool)


@pytest.mark.slow
def test_a_dask_cluster_gives_the_forked_comparison(forked, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        energy = compare_sequences(_task("energy"), dask=cluster.scheduler_address)
        newton = compare_sequences(_task("newton"), dask=cluster.scheduler_address)
    assert _doc(newton) == _doc(forked)
    assert _doc(energy) == _doc(compare_sequences(_task("energy"), jobs=2))


def test_legs_share_a_node_only_when_everything_that_plans_them_is_the_same():
    """Stratum, method, duration and via (and what the next leg's inputs ask of its end):
    two sequences whose first legs differ in duration alone plan that leg twice."""
    import numpy as np

    from stratcli.models.presets import preset
    from stratcli.settings import PlannerSettings
    from stratcli.stratified import LegSpec
    from stratcli.trie import build_trie

    system, settings = preset("one-arm"), PlannerSettings()
    via, goal = np.array([0.1, 0.2, 0.0, 0.0]), np.array([0.1, 0.2, 0.3, 0.1])

    def leg(stratum, to, duration=1.0):
        return LegSpec(stratum=stratum, goal=to, method="newton", duration=duration)

    other = goal + np.array([0.0, 0.0, 0.1, 0.0])
    same = [[leg("S3", via), leg("S1", goal)], [leg("S3", via), leg("S1", other)]]
    nodes, paths = build_trie(system, settings, same)
    assert paths[0][0] == paths[1][0] and len(nodes) == 3  # the first leg planned once
    longer = [[leg("S3", via), leg("S1", goal)], [leg("S3", via, 2.0), leg("S1", goal)]]
    nodes, paths = build_trie(system, settings, longer)
    assert paths[0][0] != paths[1][0] and len(nodes) == 4
