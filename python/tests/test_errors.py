"""Every documented bad input raises the documented exception, naming the
argument (python/README.md, "Errors")."""

import numpy as np
import pytest

import beamest
from beamest import link

U = np.sin(np.arange(4000) * 0.01)
Y = np.cos(np.arange(4000) * 0.01)


@pytest.mark.parametrize("call,exc,match", [
    (lambda: beamest.replay(U, Y), TypeError, "exactly one of ts"),
    (lambda: beamest.replay(U, Y, ts=1e-4, t=np.arange(4000) * 1e-4), TypeError, "exactly one of ts"),
    (lambda: beamest.replay(U, Y, ts="0.1"), TypeError, "^ts:"),
    (lambda: beamest.replay(U, Y, ts=-1.0), ValueError, "^ts:"),
    (lambda: beamest.replay(U, Y, ts=float("nan")), ValueError, "^ts:"),
    (lambda: beamest.replay(U, Y[:10], ts=1e-4), ValueError, "^y: u and y must have the same length"),
    (lambda: beamest.replay(np.ones((2, 2000)), Y, ts=1e-4), ValueError, "^u: expected a 1-D array"),
    (lambda: beamest.replay(["a", "b"], Y, ts=1e-4), TypeError, "^u: expected real numbers"),
    (lambda: beamest.replay(U + 1j, Y, ts=1e-4), TypeError, "^u: expected real numbers"),
    (lambda: beamest.replay([], [], ts=1e-4), ValueError, "^u: no samples"),
    (lambda: beamest.replay(U, Y, t=np.r_[0.0, 0.0, np.arange(2, 4000) * 1e-4]), ValueError, r"^t\[1\]: the time column does not increase"),
    (lambda: beamest.replay(U, Y, t=np.r_[np.arange(2000), np.arange(2000) * 1.5 + 2000] * 1e-4), ValueError, r"^t\[\d+\]: non-uniform sampling"),
    (lambda: beamest.replay(U, Y, t=np.arange(10) * 1e-4), ValueError, "^t: must have one time per sample"),
    (lambda: beamest.replay(U, Y, ts=1e-4, bogus=1), TypeError, "unexpected keyword argument 'bogus'"),
    (lambda: beamest.replay(U, Y, ts=1e-4, columns="a,b"), TypeError, "unexpected keyword argument 'columns'"),
    (lambda: beamest.replay(U, Y, ts=1e-4, estimator="kalman"), ValueError, "'kalman' for 'estimator"),
    (lambda: beamest.replay(U, Y, ts=1e-4, modes=4), ValueError, "modes"),
    (lambda: beamest.replay(U, Y, ts=1e-4, lambda_=-5.0), ValueError, "lambda"),
    (lambda: beamest.replay(U, Y, ts=1e-4, modes=2, weights=(1.0,)), ValueError, "^weights: expected 2 values"),
    (lambda: beamest.replay(U, Y, ts=1e-4, weights=(1.0, 2.0, 3.0, 4.0)), ValueError, "^weights: expected 2 values"),
    (lambda: beamest.replay(U, Y, ts=1e-4, level_correction=1), TypeError, "^level_correction: expected True or False"),
    (lambda: beamest.replay(U, Y, ts=1e-4, band_hz={"a": 1}), TypeError, "^band_hz:"),
    (lambda: beamest.replay(U, Y, ts=1e-4, series_hz=0.0), ValueError, "^series_hz:"),
    (lambda: beamest.replay(U, Y, ts=1e-4, paper_gains=True, estimator="feedthrough"), ValueError, "feedthrough"),
    (lambda: beamest.Estimator(1e-4, crlb=True), TypeError, "unexpected keyword argument 'crlb'"),
    (lambda: beamest.Estimator(1e-4, rate_hz=-1), ValueError, "^rate_hz:"),
    (lambda: beamest.Estimator(0.0), ValueError, "^ts:"),
    (lambda: beamest.Estimator(1e-4).step(U, Y[:3]), ValueError, "^y: u and y must have the same length"),
    (lambda: beamest.Estimator(1e-4).reports(U), ValueError, "^y: required with u"),
    (lambda: beamest.Estimator(1e-4).reports(y=Y), ValueError, "^u: required with y"),
    (lambda: beamest.Estimator(1e-4).reports(U, Y[:3]), ValueError, "^y: u and y must have the same length"),
    (lambda: beamest.Estimator(1e-4).reports(U, ["a"] * 4000), TypeError, "^y: expected real numbers"),
    (lambda: beamest.read_replay_csv("/nonexistent/x.csv"), FileNotFoundError, "no such file"),
    (lambda: beamest.read_replay_csv(__file__), ValueError, "line 1: no column named"),
    (lambda: beamest.read_replay_csv(__file__, columns=("a",)), ValueError, "^columns:"),
    (lambda: beamest.crlb(), ValueError, "snr_db"),
    (lambda: beamest.simulate(duration=-1.0), ValueError, "^duration:"),
    (lambda: beamest.beam_model(modes=0), ValueError, "modes"),
    (lambda: beamest.beam_model(beam="/nonexistent.toml"), ValueError, "beam"),
    (lambda: link.Decoder().feed("text"), TypeError, "^data: expected bytes"),
    (lambda: link.Decoder(joining=1), TypeError, "^joining:"),
    (lambda: link.encode_command("launch"), ValueError, "^command:"),
    (lambda: link.encode_command(b"freeze"), TypeError, "^line:"),
    (lambda: link.encode_command("freeze", seq=-1), ValueError, "^seq:"),
    (lambda: link.encode_command("freeze", seq=1.5), TypeError, "^seq:"),
])
def test_bad_input_raises(call, exc, match):
    with pytest.raises(exc, match=match):
        call()
