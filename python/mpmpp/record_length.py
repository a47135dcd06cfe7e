"""Segment, block and window lengths that scale with the record.

Historian exports are often only a few hours long (a 2 h export at 10 s is 751 rows), while the
analyses were first written with 1 h segments in mind. Every analysis asks here for its lengths:
the preferred length in seconds when the record is long enough, otherwise a fixed share of the
record, never below a floor in rows that keeps each estimate meaningful. Below the analysis's
minimum the answer is one line: "too short: N rows (H h); need at least M".
"""
from __future__ import annotations

# Fewest rows any analysis accepts: a SISO ARX-OE with the noise and dead-time orders searched
# here has up to ~15 parameters, and ~10 equations per parameter keep their spread moderate.
MIN_ROWS = 150


def too_short(rows: int, sample_time_s: float, need: int) -> ValueError:
    """The one-line error for a record below ``need`` rows."""
    return ValueError(f"too short: {rows} rows ({rows * sample_time_s / 3600:.2g} h); need at least {need}")


def require_rows(rows: int, sample_time_s: float, need: int = MIN_ROWS) -> None:
    if rows < need:
        raise too_short(rows, sample_time_s, need)


def scaled_rows(rows: int, sample_time_s: float, preferred_s: float, parts: int, floor: int) -> int:
    """Length in rows of one of ``parts`` pieces of the record: ``preferred_s`` when the record
    holds ``parts`` of those, else rows // parts, never below ``floor``.

    Example: segments of 1 h in thirds of the record with a 50-row floor give 360 rows for a
    6 h record at 10 s and 250 rows (42 min) for a 751-row, 2 h record."""
    if sample_time_s <= 0:
        raise ValueError(f"sample time must be > 0 s, got {sample_time_s}")
    if parts < 1 or floor < 1:
        raise ValueError("parts and floor must be >= 1")
    preferred = max(int(round(preferred_s / sample_time_s)), 1)
    return max(min(preferred, rows // parts), floor)


def minimum_rows(parts: int, floor: int) -> int:
    """The fewest rows that hold ``parts`` pieces of at least ``floor`` rows (and MIN_ROWS)."""
    return max(parts * floor, MIN_ROWS)
