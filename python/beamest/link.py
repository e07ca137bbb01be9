"""The serial link (docs/PROTOCOL.md) from Python: the core's stream
decoder, the one ``beamctl monitor`` runs, fed with bytes from pyserial, a
socket or a capture file; frames come out as dataclasses. Commands are
encoded from ``beamctl send``'s grammar."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple, Union

from . import _beamest

__all__ = [
    "Decoder",
    "Estimate",
    "RawSamples",
    "Status",
    "Ack",
    "SelfTestReport",
    "CommandEcho",
    "FrameError",
    "LinkCounters",
    "Frame",
    "encode_command",
]


@dataclass(frozen=True)
class Estimate:
    """The device's current estimate (PROTOCOL.md §4.1). f32 on the wire,
    given here as the same values in float."""

    seq: int
    sample_index: int
    #: the law: adaptive, gradient, ls, robust
    estimator: str
    #: StatusFlags bits
    flags: int
    #: their names (EXCITED, PHYSICALLY_VALID, ...)
    flag_names: Tuple[str, ...]
    #: ω̂_i (rad/s), one per mode the estimate has
    omega: Tuple[float, ...]
    zeta: Tuple[float, ...]
    bbar: Tuple[float, ...]
    #: λ of the filter Λ(s) = (s + λ)^{2n} that theta belongs to (rad/s)
    lambda_rad_s: float
    #: Θ̂ of eq. 29, physical units
    theta: Tuple[float, ...]
    #: λmin(P)/tr(P) in [0, 1] (Lemma 1; EXCITED tests it), None when not measured
    excitation_level: Optional[float]
    kind: str = "estimate"


@dataclass(frozen=True)
class RawSamples:
    """A block of raw (u, y) samples (PROTOCOL.md §4.2)."""

    seq: int
    first_sample_index: int
    decimation: int
    u: Tuple[float, ...]
    y: Tuple[float, ...]
    kind: str = "raw"


@dataclass(frozen=True)
class Status:
    """Counters and current settings (PROTOCOL.md §4.3)."""

    seq: int
    uptime_samples: int
    sample_rate_hz: float
    firmware: str
    modes: int
    counters: Dict[str, int]
    adaptation_frozen: bool
    waveform: str
    waveform_params: str
    amplitude_v: float
    offset_v: float
    estimator: str
    gain: float
    forgetting_p: float
    forgetting_h: float
    initial_gain: float
    #: the λ in use (rad/s), None before the automatic rule has chosen
    lambda_rad_s: Optional[float]
    #: the sensor output kind the estimator models: strain, velocity, acceleration
    output: str
    estimate_rate_hz: float
    raw_decimation: int
    status_rate_hz: float
    #: λ is the device's automatic rule's (may change without a command)
    lambda_automatic: bool
    #: the self-test: "not run", "running", "passed", or "failed: …" /
    #: "not measured: …" with the checks' names
    self_test: str
    kind: str = "status"


@dataclass(frozen=True)
class Ack:
    """The answer to a command (PROTOCOL.md §4.4)."""

    seq: int
    command_seq: int
    #: accepted, or the reject reason's name (SafeWindow, ...)
    result: str
    detail: str
    kind: str = "ack"


@dataclass(frozen=True)
class SelfTestReport:
    """The result of the device's self-test (PROTOCOL.md §4.5). Values not
    measured are NaN."""

    seq: int
    first_sample: int
    last_sample: int
    #: the self-test at start-up (else one started by a SelfTest command)
    at_boot: bool
    #: every check passed
    passed: bool
    #: the checks that failed / could not be measured: adc_id,
    #: adc_registers, drdy_rate, loopback, noise
    failed: Tuple[str, ...]
    not_measured: Tuple[str, ...]
    adc_id: int
    #: MODE, CLOCK, GAIN1 as read back and as configured (masked)
    adc_registers: Tuple[int, ...]
    adc_expected: Tuple[int, ...]
    drdy_rate_hz: float
    drdy_expected_hz: float
    #: relative
    drdy_tolerance: float
    conversions: int
    ticks: int
    tone_hz: float
    tone_amplitude_v: float
    loopback_gain: float
    expected_gain: float
    #: relative
    gain_tolerance: float
    offset_v: float
    offset_tolerance_v: float
    delay_samples: float
    expected_delay_samples: float
    delay_tolerance_samples: float
    #: σ of y with the drive at zero (units of y)
    noise_sd: float
    #: one code of y / √12
    floor_sd: float
    #: RMS of y under ``excitation``
    signal_rms: float
    snr_db: float
    snr_min_db: float
    #: the default excitation, in ``beamctl send`` syntax
    excitation: str
    kind: str = "selftest"


@dataclass(frozen=True)
class CommandEcho:
    """A host → device frame received from the device side (a loop-back)."""

    seq: int
    #: the command in ``beamctl send`` syntax
    command: str
    kind: str = "command_echo"


@dataclass(frozen=True)
class FrameError:
    """A frame that did not decode (only with ``Decoder(keep_errors=True)``)."""

    #: why it was dropped (``CRC mismatch (corrupted frame)``, ...)
    detail: str
    kind: str = "error"


@dataclass(frozen=True)
class LinkCounters:
    """What the decoder has seen since it was made."""

    bytes: int
    skipped_bytes: int
    frames_ok: int
    crc_errors: int
    framing_errors: int
    oversize: int
    malformed: int
    version_mismatches: int
    #: frames missing from the sequence numbers
    lost: int
    duplicates: int
    out_of_order: int
    #: frames received but not delivered for an error (CRC + framing +
    #: oversize + malformed + version mismatches; duplicates are counted
    #: apart, and not delivered either)
    errors: int
    #: bytes after the last delimiter (a frame not finished yet)
    partial_bytes: int


Frame = Union[Estimate, RawSamples, Status, Ack, SelfTestReport, CommandEcho, FrameError]

_TUPLES = (
    "flag_names",
    "omega",
    "zeta",
    "bbar",
    "theta",
    "u",
    "y",
    "failed",
    "not_measured",
    "adc_registers",
    "adc_expected",
)
_CLASSES = {
    "estimate": Estimate,
    "raw": RawSamples,
    "status": Status,
    "ack": Ack,
    "selftest": SelfTestReport,
    "command_echo": CommandEcho,
    "error": FrameError,
}


def _frame(d: dict) -> Frame:
    for k in _TUPLES:
        if k in d:
            d[k] = tuple(d[k])
    return _CLASSES[d["kind"]](**d)


class Decoder:
    """The stream decoder. ``joining=True`` for a stream joined while
    running (bytes before the first delimiter are skipped, not errors);
    ``keep_errors=True`` to get a :class:`FrameError` for each frame
    dropped, in place."""

    def __init__(self, joining: bool = False, keep_errors: bool = False):
        if not isinstance(joining, bool):
            raise TypeError(f"joining: expected True or False, got {type(joining).__name__}")
        if not isinstance(keep_errors, bool):
            raise TypeError(f"keep_errors: expected True or False, got {type(keep_errors).__name__}")
        self._core = _beamest.DecoderCore(joining, keep_errors)

    def feed(self, data: Union[bytes, bytearray, memoryview]) -> List[Frame]:
        """Feed bytes (any split: a frame may span calls); the frames they
        completed, in order."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"data: expected bytes, got {type(data).__name__}")
        return [_frame(d) for d in self._core.feed(bytes(data))]

    @property
    def counters(self) -> LinkCounters:
        """The link counters (lost, CRC, framing, ...)."""
        return LinkCounters(**self._core.counters())

    def encode_command(self, line: str, seq: int = 0) -> bytes:
        """:func:`encode_command`, the settings a command does not give
        taken from the last Status this decoder delivered (as ``beamctl
        send`` does)."""
        return self._core.encode_command(_line(line), _seq(seq))


def _line(line) -> str:
    if not isinstance(line, str):
        raise TypeError(f"line: expected a string, got {type(line).__name__}")
    return line


def _seq(seq) -> int:
    if isinstance(seq, bool) or not isinstance(seq, int):
        raise TypeError(f"seq: expected an int, got {type(seq).__name__}")
    if not 0 <= seq < 2**32:
        raise ValueError(f"seq: must be in 0..2**32 (got {seq})")
    return seq


def encode_command(line: str, seq: int = 0) -> bytes:
    """The bytes of one host → device command frame (a leading delimiter,
    then the frame) for a ``beamctl send`` command line: ``"freeze"``,
    ``"status"``, ``"excitation --wave chirp --band 1:100 --sweep 10
    --amplitude 0.2 --offset 0"``. Without a device's Status every setting
    of excitation/estimator/telemetry must be given (else ValueError; see
    :meth:`Decoder.encode_command`)."""
    return _beamest.encode_command(_line(line), _seq(seq))
