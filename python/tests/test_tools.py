"""simulate, crlb and beam_model: the CLI's JSON documents."""

import json

import beamest


def test_simulate_equals_the_cli(beamctl):
    want = json.loads(beamctl("simulate", "--duration", "2", "--snr-db", "50", "--json").stdout)
    assert beamest.simulate(duration=2, snr_db=50) == want


def test_crlb_equals_the_cli(beamctl):
    want = json.loads(beamctl("crlb", "--snr-db", "40", "--duration", "5", "--json").stdout)
    assert beamest.crlb(snr_db=40, duration=5) == want


def test_beam_model_equals_the_cli(beamctl):
    want = json.loads(beamctl("model", "--modes", "3", "--beam", "beamctl/examples/paper-beam.toml", "--json").stdout)
    got = beamest.beam_model(modes=3, beam=str(beamest_repo() / "beamctl/examples/paper-beam.toml"))
    # The source names the file as given.
    want.pop("source", None)
    got.pop("source", None)
    assert got == want


def beamest_repo():
    import pathlib
    return pathlib.Path(__file__).resolve().parents[2]
