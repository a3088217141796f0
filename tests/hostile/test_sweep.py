"""The hostile sweep's CI sample (issue 33): about 70 probes spread over every surface of
``sweep.py`` (bad files, G-code lines, HP-GL, profiles, settings) in one child process; every one
must be a clean error or a correct run. ``bench/hostile.py`` runs all of them."""

from pathlib import Path

import pytest
import sweep


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    every = sweep.probes(Path(folder))
    return every, sweep.run(sweep.sample(every, 70), Path(folder))


def test_every_probe_of_the_sample_is_a_clean_error_or_a_correct_run(results):
    _, done = results
    failed = [f"{r['surface']}: {r['name']}: {r['why']}" for r in done if r["verdict"] == "failure"]
    assert not failed, "\n".join(failed)


def test_the_sample_covers_every_surface_and_both_verdicts(results):
    every, done = results
    assert (
        {r["surface"] for r in done}
        == {p.surface for p in every}
        == {"files", "gcode lines", "hpgl", "profiles", "settings"}
    )
    assert {r["verdict"] for r in done} == {"clean error", "correct"} and len(done) >= 60


def test_the_judge_counts_what_breaks_as_failures(tmp_path):
    # A run that succeeds on a wrong input, and one that refuses a right one, are failures.
    (tmp_path / "config").mkdir()
    (tmp_path / "ok.svg").write_text(sweep._SVG)
    probes = [
        sweep.Probe("t", "wrong but accepted", ["stat", "ok.svg", "-q"]),
        sweep.Probe("t", "right but refused", ["stat", "missing.svg", "-q"], good=True),
        sweep.Probe("t", "right", ["stat", "ok.svg", "-q"], good=True),
    ]
    verdicts = [r["verdict"] for r in sweep.run(probes, tmp_path)]
    assert verdicts == ["failure", "failure", "correct"]
