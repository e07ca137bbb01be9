"""beamest.link: the decoder against `beamctl monitor --file` on captures
of the fake device (beamctl's link::fake, written by its fake_device
example) and of the emulated firmware (`cargo xtask qemu`'s UART0 file,
given by $QEMU_CAPTURE: .ci/run sets it), arbitrary bytes, commands."""

import csv
import os
import random
from pathlib import Path

import numpy as np
import pytest

import beamest
from beamest import link


def same_f32(v, text):
    """v (an f32 widened to float) is the f32 the recorder wrote as text
    (its shortest decimal)."""
    return np.float32(v) == np.float32(float(text))


def corrupt(clean: bytes) -> bytes:
    """The corruptions of beamctl's test
    capture_with_corruption_counts_as_the_decoder_does."""
    frames = [f + b"\0" for f in clean.split(b"\0")[:-1]]
    out = bytearray()
    for i, f in enumerate(frames):
        f = bytearray(f)
        if i == 5:
            k = len(f) // 2
            f[k] ^= 0x10
            if f[k] == 0:
                f[k] = 0x10
        elif i == 10:
            continue
        elif i == 30:
            f += b"\x01\x02\x03\x00"
        elif i == 40:
            f[-1] = 0x55
        out += f
    out += frames[7][: len(frames[7]) // 2]
    return bytes(out)


@pytest.mark.parametrize("damaged", [False, True])
def test_decoder_equals_monitor_file(beamctl, fake_device, tmp_path, damaged):
    data = fake_device(tmp_path / "clean.bin", 20_000)
    if damaged:
        data = corrupt(data)
    frames, counters = decode_as_monitor_does(beamctl, data, tmp_path)
    if damaged:
        assert (counters.lost, counters.errors) == (4, 3)
        assert counters.partial_bytes > 0


def test_decoder_equals_monitor_file_on_a_qemu_capture(beamctl, tmp_path):
    path = os.environ.get("QEMU_CAPTURE")
    if not path:
        pytest.skip("no QEMU capture: set $QEMU_CAPTURE to `cargo xtask qemu`'s UART0 file")
    data = Path(path).read_bytes()
    frames, counters = decode_as_monitor_does(beamctl, data, tmp_path)
    kinds = {f.kind for f in frames}
    # The emulated firmware's stream: estimates and a status, nothing lost.
    assert {"estimate", "status"} <= kinds, kinds
    assert (counters.lost, counters.errors) == (0, 0)
    # Every estimate means what PROTOCOL.md §4.1 says: EXCITED is the
    # firmware's test of the level sent (≥ 1e-7, §9.3, and INPUT_GONE
    # clear); Θ̂ = 0 carries no modes and no PHYSICALLY_VALID; λ > 0.
    estimates = [f for f in frames if f.kind == "estimate"]
    for e in estimates:
        gone = "INPUT_GONE" in e.flag_names
        level_ok = e.excitation_level is not None and np.float32(e.excitation_level) >= np.float32(1e-7)
        assert ("EXCITED" in e.flag_names) == (level_ok and not gone), e
        if all(t == 0.0 for t in e.theta):
            assert e.omega == () and "PHYSICALLY_VALID" not in e.flag_names, e
        assert e.lambda_rad_s > 0.0
    # The first estimates (the law held at start-up) have no modes; later
    # ones do.
    assert estimates[0].omega == ()
    assert any(len(e.omega) == 2 for e in estimates)
    # The self-test at start-up: one report, every check passed, the
    # values of the simulated bench (PROTOCOL.md §9.7).
    [report] = [f for f in frames if f.kind == "selftest"]
    assert report.at_boot and report.passed, report
    assert report.failed == () and report.not_measured == ()
    assert report.adc_id >> 8 == 0x22 and report.adc_registers == report.adc_expected
    assert report.drdy_rate_hz == report.drdy_expected_hz == 10_000.0
    assert abs(report.delay_samples - 2.15) < 1e-3 and report.snr_db >= report.snr_min_db
    statuses = [f for f in frames if f.kind == "status"]
    assert statuses[0].self_test == "running" and statuses[-1].self_test == "passed"


def decode_as_monitor_does(beamctl, data, tmp_path):
    """Decode `data` with beamest.link.Decoder and with `beamctl monitor
    --file … --record`, assert the two agree frame by frame, and return the
    decoder's frames and counters."""
    cap = tmp_path / "cap.bin"
    cap.write_bytes(data)
    rec = tmp_path / "rec.csv"
    beamctl("monitor", "--file", cap, "--record", rec, "--plain")
    with open(rec, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["kind"] != "end"]

    d = link.Decoder(keep_errors=True)
    frames = []
    for k in range(0, len(data), 4096):  # as a serial port delivers them
        frames += d.feed(data[k:k + 4096])
    assert [f.kind for f in frames] == [r["kind"] for r in rows]
    for f, r in zip(frames, rows):
        if f.kind == "error":
            assert f.detail == r["detail"]
            continue
        assert f.seq == int(r["seq"])
        if f.kind == "estimate":
            assert f.sample_index == int(r["sample_index"])
            assert f.estimator == r["estimator"] and f.flags == int(r["flags"])
            assert "|".join(f.flag_names) == r["detail"]
            for i, (w, z, b) in enumerate(zip(f.omega, f.zeta, f.bbar), 1):
                assert same_f32(w, r[f"omega_{i}"])
                assert same_f32(z, r[f"zeta_{i}"])
                assert same_f32(b, r[f"bbar_{i}"])
            for i, th in enumerate(f.theta, 1):
                assert same_f32(th, r[f"theta_{i}"])
            assert same_f32(f.lambda_rad_s, r["lambda_rad_s"])
            if f.excitation_level is None:
                assert r["excitation_level"] == ""
            else:
                assert same_f32(f.excitation_level, r["excitation_level"])
                assert 0.0 <= f.excitation_level <= 1.0
        elif f.kind == "raw":
            assert f.first_sample_index == int(r["sample_index"])
            assert f.decimation == int(r["decimation"]) and len(f.u) == int(r["samples"])
        elif f.kind == "selftest":
            assert f.first_sample == int(r["sample_index"])
            assert f.passed == (r["self_test"] == "passed")
        elif f.kind == "status":
            assert f.self_test == r["self_test"]
            assert f.uptime_samples == int(r["sample_index"])
            assert f.waveform == r["waveform"] and f.waveform_params == r["waveform_params"]
            assert f.firmware == r["firmware"] and f.modes == int(r["modes"])
            assert f.counters["overruns"] == int(r["overruns"])
            assert int(f.lambda_automatic) == int(r["lambda_automatic"])
            assert f.output == r["output"] == "strain"
    c = d.counters
    assert c.frames_ok == sum(f.kind != "error" for f in frames)
    # Dropped: errors, and duplicates (not delivered twice, PROTOCOL.md §1.6).
    assert c.errors + c.duplicates == sum(f.kind == "error" for f in frames)
    # The raw samples are those of FILE.raw.csv, exactly.
    recording = beamest.read_recording(rec)
    raw = [f.u for f in frames if f.kind == "raw"]
    if raw:
        assert np.array_equal(np.concatenate(raw), recording.raw["u"])
    assert len(recording.kinds("estimate")) == len(recording.estimates["omega"])
    return frames, c


def test_decoder_survives_arbitrary_bytes(fake_device, tmp_path):
    clean = fake_device(tmp_path / "clean.bin", 5_000)
    rng = random.Random(17)
    for trial in range(300):
        kind = trial % 3
        if kind == 0:  # pure noise, with and without delimiters
            data = bytes(rng.randrange(256) if rng.random() > 0.05 else 0
                         for _ in range(rng.randrange(1, 3000)))
        else:  # the capture with bytes flipped, dropped or inserted
            b = bytearray(clean)
            for _ in range(rng.randrange(1, 40)):
                i = rng.randrange(len(b))
                op = rng.randrange(3)
                if op == 0:
                    b[i] = rng.randrange(256)
                elif op == 1:
                    del b[i]
                else:
                    b.insert(i, rng.randrange(256))
            data = bytes(b)
        whole = link.Decoder(joining=bool(trial & 1), keep_errors=True)
        a = whole.feed(data)
        split = link.Decoder(joining=bool(trial & 1), keep_errors=True)
        b_ = []
        k = 0
        while k < len(data):
            n = rng.randrange(1, 600)
            b_ += split.feed(data[k:k + n])
            k += n
        assert a == b_
        assert whole.counters == split.counters
        c = whole.counters
        assert c.bytes == len(data)
        assert c.frames_ok == sum(f.kind != "error" for f in a)
        assert c.errors == sum(f.kind == "error" for f in a)


def test_commands_encode_to_frames_the_decoder_reads_back(fake_device, tmp_path):
    for seq, line in [(0, "freeze"), (7, "status"),
                      (2**32 - 1, "excitation --wave chirp --band 1:100 --sweep 10 --amplitude 0.2 --offset 0")]:
        data = link.encode_command(line, seq)
        assert data[0] == 0 and data[-1] == 0
        (f,) = link.Decoder().feed(data)
        assert isinstance(f, link.CommandEcho) and f.seq == seq
    assert link.Decoder().feed(link.encode_command("freeze"))[0].command == "freeze"
    # Settings not given come from the decoder's last Status.
    with pytest.raises(ValueError, match="is needed"):
        link.encode_command("excitation --amplitude 0.2")
    d = link.Decoder()
    d.feed(fake_device(tmp_path / "c.bin", 100))
    (f,) = link.Decoder().feed(d.encode_command("excitation --amplitude 0.2", 3))
    assert f.command.startswith("excitation --wave square --freq 7") and "--amplitude 0.2" in f.command
