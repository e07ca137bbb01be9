"""Ctrl-C interrupts a long replay or step: the lock is released and the
signals are looked at between chunks of 65,536 samples."""

import _thread
import threading

import numpy as np
import pytest

import beamest


@pytest.fixture(scope="module")
def long_record(repo):
    u, y, ts = beamest.read_replay_csv(repo / "host-tests/data/replay_a.csv.gz")
    n = 5_000_000
    reps = -(-n // len(u))
    return np.tile(u, reps)[:n], np.tile(y, reps)[:n], ts


def interrupt_soon():
    """What Ctrl-C does: KeyboardInterrupt in the main thread, raised when
    the running code next looks at the signals."""
    t = threading.Timer(0.05, _thread.interrupt_main)
    t.start()
    return t


def test_ctrl_c_interrupts_replay(long_record):
    u, y, ts = long_record
    t = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        beamest.replay(u, y, ts=ts)
    t.join()


def test_ctrl_c_interrupts_step_after_whole_chunks(long_record):
    u, y, ts = long_record
    est = beamest.Estimator(ts)
    t = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        est.step(u, y)
    t.join()
    assert 0 < est.samples < len(u) and est.samples % 65_536 == 0
    # The estimator goes on from there.
    rest = est.step(u[est.samples:], y[est.samples:])
    assert est.samples == len(u) and len(rest) > 0


def test_ctrl_c_interrupts_simulate():
    t = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        beamest.simulate(duration=3600)
    t.join()


def test_ctrl_c_interrupts_simulate_seeds():
    t = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        beamest.simulate(duration=600, seeds="1..20", snr_db=40)
    t.join()


def test_ctrl_c_interrupts_crlb():
    t = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        beamest.crlb(snr_db=40, duration=36000)
    t.join()
