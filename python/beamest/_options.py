"""Keyword arguments -> a beamctl command's argument list.

Each keyword is the command's long flag with ``_`` for ``-`` (``band_hz``
for ``--band-hz``; ``lambda_`` for ``--lambda``, a Python keyword). The
compiled module parses the list with the command's own clap definition,
so names, defaults and checks are the CLI's.
"""

from __future__ import annotations

import numbers
import os
from typing import Any, Dict, Iterable, List, Tuple

from . import _beamest

_FLAGS: Dict[str, Dict[str, bool]] = {}


def flags(command: str) -> Dict[str, bool]:
    """The long flags of ``command`` -> whether each takes a value."""
    if command not in _FLAGS:
        _FLAGS[command] = dict(_beamest.option_names(command))
    return _FLAGS[command]


def _scalar(name: str, v: Any) -> str:
    if isinstance(v, bool):
        raise TypeError(f"{name}: expected a number or a string, got a bool")
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        # repr is the shortest round-trip decimal: beamctl parses it back
        # to the same float64.
        return repr(float(v))
    if isinstance(v, (str, os.PathLike)):
        return os.fspath(v)
    raise TypeError(f"{name}: expected a number, a string or a sequence of them, got {type(v).__name__}")


def argv(command: str, func: str, options: Dict[str, Any], exclude: Iterable[str] = (),
         positional: Tuple[str, ...] = ()) -> List[str]:
    """The argument list for ``options``; TypeError for an unknown keyword
    or a value of the wrong type (naming it)."""
    known = flags(command)
    banned = set(exclude)
    out = [command, *positional]
    for key, value in options.items():
        flag = key[:-1] if key.endswith("_") else key
        flag = flag.replace("_", "-")
        if flag not in known or flag in banned:
            raise TypeError(f"{func}() got an unexpected keyword argument {key!r}")
        if value is None:
            continue
        if not known[flag]:
            if not isinstance(value, bool):
                raise TypeError(f"{key}: expected True or False, got {type(value).__name__}")
            if value:
                out.append(f"--{flag}")
            continue
        if isinstance(value, (list, tuple)) or (hasattr(value, "ndim") and getattr(value, "ndim", 0) == 1):
            text = ",".join(_scalar(key, v) for v in value)
        else:
            text = _scalar(key, value)
        out.append(f"--{flag}={text}")
    return out
