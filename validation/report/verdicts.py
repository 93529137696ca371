"""The report's verdicts: one row per claim, what was measured and what it says.

Each of the core's claims is a small function of the :class:`validation.report.analysis.Analysis`;
each study (:class:`validation.report.study.Study`) adds its own rows. A claim whose
runs are missing from the study says "not measured" rather than leaving its row out.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

from results import level_label

from .analysis import Analysis


class Verdict(NamedTuple):
    """One row of the verdict table."""

    claim: str
    measured: str
    verdict: str


COLUMNS = (("claim", "claim", ""), ("measured", "measured", ""), ("verdict", "verdict", ""))
"""The verdict table's columns (:class:`validation.common.document.Table`)."""

NOT_MEASURED = "not measured"


def held(hits: int, cases: int, what: str) -> str:
    """The verdict of a claim that held in ``hits`` of ``cases`` (``what``: their plural noun)."""
    return "holds" if hits == cases else "does not hold" if hits == 0 else f"holds at {hits} of {cases} {what}"


def one_problem(a: Analysis) -> Verdict:
    """DR and the FEM minimise one discrete energy: their refined limits agree."""
    claim = "DR on the FEM's discrete problem refines to the FEM's limit"
    rows = [r for r in a.limits if "agree" in r]
    if not rows:
        return Verdict(claim, "no refined limits of both solvers", NOT_MEASURED)
    agree = [r for r in rows if r["agree"]]
    worst = max(rows, key=lambda r: abs(r["theta_diff"]))
    measured = (f"limits within their error estimates at {len(agree)} of {len(rows)} pre-stretch levels; "
                f"largest difference {abs(worst['theta_diff']):.3g} deg at lambda = {level_label(worst['prestretch'])}")
    return Verdict(claim, measured, held(len(agree), len(rows), "levels"))


def first_contact(a: Analysis) -> Verdict:
    """Where the curl brings the frame onto the film: the sweep's physical range."""
    claim = "The curled frame stays clear of the film over the sweep"
    rows = [r for r in a.first_contact if r["level"] == "extrapolated"]
    if not rows:
        return Verdict(claim, "no first contact located", NOT_MEASURED)
    c = rows[0]
    top = max(a.plan.sweep)
    measured = f"first contact at lambda = {c['value']:.4g} +- {c['error']:.2g} (FEM levels {', '.join(c['levels'])})"
    verdict = ("holds" if c["value"] - c["error"] > top
               else f"holds up to lambda = {c['value'] - c['error']:.3g}; states above are past contact")
    return Verdict(claim, measured, verdict)


CLAIMS: tuple[Callable[[Analysis], Verdict], ...] = (one_problem, first_contact)
"""The core's claims, in the order of the table."""


def verdicts(a: Analysis) -> list[Verdict]:
    """The rows of the core's claims."""
    return [claim(a) for claim in CLAIMS]
