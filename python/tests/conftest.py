"""Shared fixtures: the repository, the beamctl binary the Python results
are compared with, and the fake device that writes link captures.

The binaries come from $BEAMCTL / $FAKE_DEVICE, else from the repository's
target/ (release, then debug: `cargo build -p beamctl --example
fake_device`). A missing binary is an error, not a skip: these tests
exist to compare against it."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def _binary(env: str, *relative: str) -> pathlib.Path:
    given = os.environ.get(env)
    if given:
        return pathlib.Path(given)
    for profile in ("release", "debug"):
        p = REPO / "target" / profile / pathlib.Path(*relative)
        if p.exists():
            return p
    raise RuntimeError(f"no {'/'.join(relative)} under {REPO}/target: build it or set ${env}")


@pytest.fixture(scope="session")
def beamctl():
    exe = _binary("BEAMCTL", "beamctl")

    def run(*args, check=True):
        p = subprocess.run([str(exe), *map(str, args)], cwd=REPO, capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"beamctl {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
        return p

    return run


@pytest.fixture(scope="session")
def fake_device():
    exe = _binary("FAKE_DEVICE", "examples", "fake_device")

    def write(path, samples, raw_decimation=10):
        subprocess.run([str(exe), "--write", str(path), "--samples", str(samples),
                        "--raw-decimation", str(raw_decimation)], check=True, capture_output=True)
        return pathlib.Path(path).read_bytes()

    return write


@pytest.fixture(scope="session")
def repo():
    return REPO
