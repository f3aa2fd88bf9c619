"""How a run's error reads beside its uncertainty and beside the steps the reference left unsolved: the text
every output prints, and the order fronts, winners and plots put runs in.

**Uncertainty.** A planar step may have more than one exact answer (a pile resting on friction does), and the
reference finds one of them. The run's error dict carries ``spread`` (m/s, RMS over steps and boxes like
``rms``): how far apart the exact answers found lie, so how far the error could move had another exact answer
been taken. A column run's dict has none: its reference answer is unique, its spread 0.

- An error at or below its spread (``within``) cannot be told from zero: it reads ``<= SPREAD``, never as a
  number that ranks it below another. An error above its spread reads ``RMS ± SPREAD`` (``RMS`` alone when
  the spread is 0).
- A run's **stated error** (``stated``) is ``max(rms, spread)``: the figure it can claim. An error level
  ``t`` is reached when the stated error is at most ``t`` (``reaches``); plots draw the run at it.
- A run's **interval** is ``[max(0, rms - spread), rms + spread]``: where its error against any exact answer
  may lie. Two runs are **tied on error** when their intervals overlap (``tied``): neither is known to be
  the more accurate, so cost decides between them. Every two runs within their spreads are tied (both
  intervals hold 0); a run above its spread still compares by its number with any run whose interval lies
  clear of its own. ``a`` is **more accurate** than ``b`` when ``a``'s interval lies wholly below ``b``'s,
  and **at least as accurate** when tied or more accurate. With every spread 0 this is the order of the
  RMS errors as they are, ties meaning equal errors.

  The overlap is not transitive (``A`` tied with ``B``, ``B`` with ``C``, ``A`` more accurate than ``C``),
  which a front allows: a run is on it unless another beats it (``compare.dominates``).

**Unsolved steps.** Where the reference could not solve a step to its tolerance it keeps its best answer,
the error is measured against that and counted in ``rms``, and the dict says how many such steps there were
(``unsolved``) and the largest residual left (``unsolved_residual``, m/s). The run stays in plots, fronts and
winners; its error text says both: ``0.0124 (3 steps unsolved, residual <= 2.4e-6 m/s)``.
"""

from __future__ import annotations

import math
from typing import Any

from stackx.bench.markup import number
from stackx.bench.sweep import Record

SPREAD = "spread"  # the key of a run's error holding the RMS error's uncertainty (m/s); absent or None: 0


def spread(error: dict[str, Any]) -> float:
    """The RMS error's uncertainty (m/s): 0 where the error dict has none (a column run)."""
    return float(error.get(SPREAD) or 0.0)


def within(error: dict[str, Any]) -> bool:
    """Whether the RMS error is at or below its uncertainty (which must be above 0): it cannot be told from
    zero."""
    s = spread(error)
    return s > 0.0 and float(error["rms"]) <= s


def _rms(rec: Record) -> float:
    """A run's RMS error (m/s), a NaN one (a difference that went non-finite) as the worst there is."""
    rms = float(rec.error["rms"])
    return rms if rms == rms else math.inf


def stated(rec: Record) -> float:
    """The error a run can claim (m/s): its RMS, or its uncertainty where the RMS is within it."""
    return max(_rms(rec), spread(rec.error))


def interval(rec: Record) -> tuple[float, float]:
    """Where a run's error against any exact answer may lie: its RMS less and plus its uncertainty, not below
    0."""
    rms, s = _rms(rec), spread(rec.error)
    return max(0.0, rms - s), rms + s


def more_accurate(a: Record, b: Record) -> bool:
    """Whether ``a``'s error is below ``b``'s beyond their uncertainties: ``a``'s interval lies wholly below
    ``b``'s."""
    return interval(a)[1] < interval(b)[0]


def tied(a: Record, b: Record) -> bool:
    """Whether neither run is known to be the more accurate: their intervals overlap."""
    return not more_accurate(a, b) and not more_accurate(b, a)


def at_least_as_accurate(a: Record, b: Record) -> bool:
    """Whether ``a`` is tied with ``b`` on error or more accurate."""
    return not more_accurate(b, a)


def reaches(rec: Record, level: float) -> bool:
    """Whether a run reaches an error level (m/s): its stated error is at most ``level``."""
    return stated(rec) <= level


def unsolved(error: dict[str, Any]) -> int:
    """How many steps the reference left unsolved in a run's error (0 where the dict does not say)."""
    return int(error.get("unsolved") or 0)


def figure(value: float | None, uncertainty: float | None) -> str:
    """An error figure with its uncertainty: ``<= 0.0024`` at or below it, ``0.0124 ± 0.0004`` above it,
    ``0.0124`` where there is none, ``-`` for no figure."""
    if value is None:
        return "-"
    if uncertainty and value <= uncertainty:
        return f"<= {number(uncertainty, '.2g')}"
    text = number(value)
    return text + f" ± {number(uncertainty, '.2g')}" if uncertainty else text


def short(value: float) -> str:
    """A small number in two digits, its exponent without padding: ``2.4e-6``, ``0.0012``."""
    text = format(value, ".2g")
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    return f"{mantissa}e{int(exponent)}"


def unsolved_note(error: dict[str, Any]) -> str:
    """`` (3 steps unsolved, residual <= 2.4e-6 m/s)`` after a run's error where the reference left steps
    unsolved (the residual where the dict has it); empty otherwise."""
    n = unsolved(error)
    if not n:
        return ""
    residual = error.get("unsolved_residual")
    left = f", residual <= {short(float(residual))} m/s" if residual is not None else ""
    return f" ({n} step{'s' if n > 1 else ''} unsolved{left})"


def error_text(error: dict[str, Any], unit: str = "") -> str:
    """A run's RMS error as every output prints it: the figure with its uncertainty (``figure``), ``unit``
    after it (`` m/s`` in a sentence, nothing under a header that has it), and the steps the reference left
    unsolved (``unsolved_note``); ``-`` where there is no error."""
    rms = error.get("rms")
    if rms is None:
        return "-"
    return figure(float(rms), error.get(SPREAD)) + unit + unsolved_note(error)


def carrying_unsolved(recs: list[Record]) -> list[Record]:
    """The runs of ``recs`` whose error holds steps the reference left unsolved."""
    return [r for r in recs if unsolved(r.error)]
