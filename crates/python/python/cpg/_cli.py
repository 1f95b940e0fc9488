"""What the package's command-line tools share, so that each follows the
project's rules from its first line: options checked before any work
(finite numbers within their range), files read within a bound and written
by the project's rule (``-`` is standard output; a regular file atomically;
a symlink's target; a device or FIFO in place, never replaced; the output
checked before the work, nothing half-written left behind), one line per
error and no traceback, Ctrl-C ending the tool with status 130."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Callable, Optional

#: The largest text file a tool reads (a trajectory of an hour at 1 kHz is about 100 MB).
MAX_TEXT_BYTES = 256 << 20
#: The largest small JSON file (gains) a tool reads.
MAX_JSON_BYTES = 1 << 20


def number(lo: float = -math.inf, hi: float = math.inf, *, lo_open: bool = False, what: str = "") -> Callable[[str], float]:
    """An argparse type: a finite number within [lo, hi] (lo excluded when ``lo_open``)."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: expected a number") from None
        low_ok = v > lo if lo_open else v >= lo
        if not (math.isfinite(v) and low_ok and v <= hi):
            if lo_open:
                span = f"above {lo:g}" + ("" if math.isinf(hi) else f" and at most {hi:g}")
            else:
                span = f"from {lo:g}" + (" up" if math.isinf(hi) else f" to {hi:g}")
            raise argparse.ArgumentTypeError(f"{text}: expected a finite number {span}{what}")
        return v

    return parse


def whole(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse type: a whole number within [lo, hi]."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{v}: expected a whole number from {lo} to {hi}")
        return v

    return parse


def check_finite(**values: Optional[float]) -> None:
    """Raises ValueError naming the first argument that is not a finite number (None is allowed)."""
    for name, v in values.items():
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
            raise ValueError(f"{name} = {v!r}: expected a finite number")


def read_text(path: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """A UTF-8 text file, refused as soon as it holds more than ``max_bytes``."""
    from . import _cpg

    data = _cpg._read_bounded(path, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise ValueError(f"{path}: line {line}: not UTF-8 text") from None


def check_output(path: Optional[str]) -> None:
    """Fails before any work when ``path`` cannot be written (None: no output asked)."""
    from . import _cpg

    if path is not None:
        _cpg._check_output(path)


def write_output(path: str, text: str) -> None:
    """Writes ``text`` where ``path`` points, by the project's rule."""
    from . import _cpg

    _cpg._write_output(path, text.encode("utf-8"))


def run(prog: str, main: Callable[[], int]) -> int:
    """Runs a tool's body: its errors as one line ``prog: message`` and status 2,
    Ctrl-C as ``prog: interrupted`` and status 130, never a traceback."""
    from . import CpgError

    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except (CpgError, ValueError, OSError, KeyError, TypeError) as e:
        text = str(e) if not isinstance(e, KeyError) else f"unknown name {e}"
        print(f"{prog}: {text}", file=sys.stderr)
        return 2
