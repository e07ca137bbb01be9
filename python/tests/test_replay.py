"""beamest.replay against `beamctl replay --json` on the same committed
files, bit for bit; the time column; the estimate over time."""

import gzip
import json

import numpy as np
import pytest

import beamest

FILES = ["host-tests/data/replay_a.csv.gz", "host-tests/data/replay_b.csv.gz"]


def cli_json(beamctl, path, *flags):
    return json.loads(beamctl("replay", path, "--json", *flags).stdout)


@pytest.mark.parametrize("path", FILES)
@pytest.mark.parametrize("flags,options", [
    ((), {}),
    (("--precision", "f32"), {"precision": "f32"}),
    (("--estimator", "robust", "--band-hz", "3,40"), {"estimator": "robust", "band_hz": (3, 40)}),
])
def test_replay_equals_the_cli_json(beamctl, repo, path, flags, options):
    u, y, ts = beamest.read_replay_csv(repo / path)
    r = beamest.replay(u, y, ts=ts, file=path, **options)
    assert r.to_dict() == cli_json(beamctl, path, *flags)
    # The arrays are the report's numbers.
    assert np.array_equal(r.omega, np.array(r.estimate["omega"]))
    assert r.ok and r.validity == []


def test_replay_all_is_the_cli_array(beamctl, repo):
    path = FILES[0]
    u, y, ts = beamest.read_replay_csv(repo / path)
    rs = beamest.replay(u, y, ts=ts, file=path, estimator="all", crlb=True)
    want = cli_json(beamctl, path, "--estimator", "all", "--crlb")
    assert isinstance(want, list) and len(want) == len(rs) == 4
    assert [r.to_dict() for r in rs] == want


def test_the_time_column_gives_the_readers_interval(repo):
    path = repo / FILES[0]
    with gzip.open(path, "rt") as f:
        header = f.readline().strip().split(",")
        rows = np.loadtxt(f, delimiter=",")
    t = rows[:, header.index("t")]
    u_file, y_file = rows[:, header.index("u")], rows[:, header.index("y")]
    u, y, ts = beamest.read_replay_csv(path)
    assert beamest.sample_interval(t) == ts
    assert np.array_equal(u, u_file) and np.array_equal(y, y_file)
    a = beamest.replay(u, y, t=t).to_dict()
    b = beamest.replay(u, y, ts=ts).to_dict()
    assert a == b


def test_series_is_the_estimate_over_time(repo):
    u, y, ts = beamest.read_replay_csv(repo / FILES[0])
    r = beamest.replay(u, y, ts=ts, series_hz=1000)
    s = r.series
    every = round(1e-3 / ts)
    assert s.sample[0] == every - 1 and s.sample[-1] == len(u) - 1
    assert np.all(np.diff(s.sample[:-1]) == every)
    assert s.omega.shape == (len(s), 2) and s.theta.shape == (len(s), 7)
    # The last evaluation is the final estimate.
    assert np.array_equal(s.omega[-1], r.omega) and np.array_equal(s.zeta[-1], r.zeta)
    # Before the start-up window ends there is no estimate.
    assert np.isnan(s.omega[0]).all() and s.validity[0] != 0
    # The evaluation rate changes nothing else.
    assert beamest.replay(u, y, ts=ts, series_hz=7).to_dict() == r.to_dict()


def test_non_contiguous_and_integer_inputs_are_converted(repo):
    u, y, ts = beamest.read_replay_csv(repo / FILES[0])
    uu = np.repeat(u, 2)[::2]
    assert not uu.flags.c_contiguous
    assert beamest.replay(uu, y, ts=ts).to_dict() == beamest.replay(u, y, ts=ts).to_dict()
    r = beamest.replay(list(range(-50, 50)) * 40, [0] * 4000, ts=1e-4)
    assert not r.ok and r.no_estimate_reason


def test_frf_of_the_record(repo, tmp_path):
    u, y, ts = beamest.read_replay_csv(repo / FILES[0])
    r = beamest.replay(u, y, ts=ts, file=FILES[0])
    m = r.frf()
    assert len(m.f_hz) > 5 and m.segments >= 2
    # Where u has power the model explains the (noise-free) record: H1
    # matches the identified model's response within 2 %.
    near = m.coherence > 0.99
    assert near.sum() >= 5
    rel = np.abs(m.h[near] - r.response(m.f_hz[near])) / np.abs(m.h[near])
    assert np.median(rel) < 0.02, np.median(rel)
    pytest.importorskip("matplotlib")
    out = tmp_path / "frf.png"
    r.plot_frf(out)
    assert out.stat().st_size > 10_000


def test_csv_and_plot_options_write_the_clis_files(beamctl, repo, tmp_path):
    path = FILES[1]
    cli_csv, py_csv = tmp_path / "cli.csv", tmp_path / "py.csv"
    beamctl("replay", path, "--estimator", "all", "--csv", cli_csv, "--plot", tmp_path / "cli.png")
    u, y, ts = beamest.read_replay_csv(repo / path)
    # Any series rate: the CSV keeps the CLI's 1 kHz grid.
    beamest.replay(u, y, ts=ts, file=path, estimator="all", series_hz=3,
                   csv=str(py_csv), plot=str(tmp_path / "py.png"))
    assert py_csv.read_bytes() == cli_csv.read_bytes()
    assert (tmp_path / "py.png").stat().st_size > 50_000
