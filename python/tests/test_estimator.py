"""beamest.Estimator: the replay session fed chunk by chunk."""

import numpy as np
import pytest

import beamest

PATH = "host-tests/data/replay_a.csv.gz"


def run_chunks(u, y, ts, chunk, **options):
    est = beamest.Estimator(ts, rate_hz=1000, **options)
    parts = []
    for k in range(0, len(u), chunk):
        parts.append(est.step(u[k:k + chunk], y[k:k + chunk]))
    assert est.samples == len(u)
    series = {}
    for name in ("sample", "t", "omega", "zeta", "b_bar", "theta", "lambda_rad_s", "validity", "excited"):
        series[name] = np.concatenate([getattr(p.series[0], name) for p in parts])
    return series, est.reports()


@pytest.mark.parametrize("options", [{}, {"precision": "f32", "estimator": "robust"}])
def test_chunks_of_1_7_and_100000_give_identical_results(repo, options):
    u, y, ts = beamest.read_replay_csv(repo / PATH)
    results = [run_chunks(u, y, ts, c, **options) for c in (1, 7, 100_000)]
    s1, r1 = results[0]
    assert len(s1["sample"]) == len(u) // 10
    for s, r in results[1:]:
        assert r == r1
        for k in s1:
            assert np.array_equal(s[k], s1[k], equal_nan=s[k].dtype.kind == "f"), k


def test_the_stream_ends_at_the_replay_estimate(repo):
    u, y, ts = beamest.read_replay_csv(repo / PATH)
    est = beamest.Estimator(ts, rate_hz=10)
    got = est.step(u, y)
    # The stream runs the firmware's default, the adaptive law with 2 modes
    # (it cannot choose a model before it has the record, as replay does).
    full = beamest.replay(u, y, ts=ts, estimator="adaptive").to_dict()
    assert beamest.replay(u, y, ts=ts).to_dict()["selection"] is not None
    (report,) = est.reports()
    assert report["estimate"] == full["estimate"]
    assert report["fit_percent"] is None
    # Given the record, the fit and the verdict are the replay's, bit for bit.
    (with_fit,) = est.reports(u, y)
    assert with_fit["fit_percent"] == full["fit_percent"] and with_fit["fit_percent"] > 90
    assert with_fit["verdict"] == full["verdict"] and with_fit["verdict"]["trusted"]
    assert report["verdict"]["reasons"][0]["code"] == "no_fit"
    judged = ("fit_percent", "verdict")
    assert {k: v for k, v in with_fit.items() if k not in judged} == \
        {k: v for k, v in report.items() if k not in judged}
    # Over a recent window: a fit of its own.
    (window,) = est.reports(u[-5000:], y[-5000:])
    assert window["fit_percent"] is not None and window["fit_percent"] != full["fit_percent"]
    for key in ("law_updates", "rejected_samples", "builds", "lambda_rad_s", "guard", "supervision", "validity"):
        assert report[key] == full[key], key
    # Evaluations on the same 0.1 s grid as the replay's series (the
    # record's last sample is on it).
    assert len(u) % est.every == 0
    assert np.array_equal(got["adaptive"].sample,
                          beamest.replay(u, y, ts=ts, estimator="adaptive").series.sample)


def test_empty_chunks_and_all_estimators(repo):
    u, y, ts = beamest.read_replay_csv(repo / PATH)
    est = beamest.Estimator(ts, estimator="all")
    assert est.names == ["adaptive", "gradient", "ls", "robust"]
    e = est.step(np.array([]), np.array([]))
    assert len(e) == 0 and est.samples == 0
    e = est.step(u[:5000], y[:5000])
    assert len(e["robust"]) == 5000 // est.every
