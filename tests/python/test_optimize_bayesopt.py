"""End to end: yamor-optimize with the bayesopt plugin against two real yamord (issue 33).

The quadruped's Table 6.1 problem with short evaluations: the run spends its
budget in batches over both daemons, every candidate obeys the configuration's
<constrain> rules, and the same seed gives the same run.
"""

from __future__ import annotations

import json

from test_optimize import CONFIG, SHORT, read_csv, run_optimize, two_daemons  # noqa: F401 (fixture)


def bayesopt_args(daemons, out, seed=3):
    return ["--plugin", "bayesopt", "--config", str(CONFIG), "--hosts", ",".join(daemons), *SHORT,
            "--set", "max_evaluations=10", "--set", "batch=2", "--seed", str(seed), "--no-plot",
            "--no-video", "--out", str(out)]


def test_bayesopt_learns_on_two_daemons_within_the_constrain_rules(two_daemons, tmp_path):
    run_optimize(bayesopt_args(two_daemons, tmp_path / "a"))
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["plugin"]["name"] == "bayesopt"
    assert summary["status"] == "budget" and summary["evaluations"] == 10
    rows = read_csv(tmp_path / "a" / "evaluations.csv")
    assert len(rows) == 10
    assert {r["host"] for r in rows} == set(two_daemons)  # the batches used both daemons
    for r in rows:
        assert r["amplitude.1"] == r["amplitude.2"] == r["amplitude.3"] == r["amplitude.0"]
        assert r["amplitude.6"] == r["amplitude.7"] == r["amplitude.8"] == r["amplitude.5"]
        assert r["offset.6"] == r["offset.7"] == r["offset.8"] == r["offset.5"]
        assert r["phase.1.6"] == r["phase.2.7"] == r["phase.0.5"]
    assert len({tuple(r[k] for k in ("amplitude.0", "amplitude.5", "offset.5", "phase.0.5")) for r in rows}) == 10
    assert summary["best"]["velocity"] == max(float(r["velocity"]) for r in rows)

    run_optimize(bayesopt_args(two_daemons, tmp_path / "b"))

    def strip_hosts(path):
        return [{k: v for k, v in r.items() if k not in ("host", "wall_seconds")}
                for r in read_csv(path / "evaluations.csv")]
    assert strip_hosts(tmp_path / "a") == strip_hosts(tmp_path / "b")
