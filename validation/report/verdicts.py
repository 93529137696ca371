"""The report's verdicts: one row per claim, what was measured and what it says.

Each claim is a small function of the :class:`validation.report.analysis.Analysis`; a study plugged in
beside the validation (:class:`validation.report.study.Study`) adds its own rows. A claim whose
runs are missing from the study says "not measured" rather than leaving its row out.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

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


def _held(hits: int, cases: int, what: str) -> str:
    """The verdict of a claim that held in ``hits`` of ``cases`` (``what``: their plural noun)."""
    return "holds" if hits == cases else "does not hold" if hits == 0 else f"holds at {hits} of {cases} {what}"


def low_cost(a: Analysis) -> Verdict:
    """The paper's claim: DR reaches a shape accuracy in less time than the FEM."""
    claim = "DR is cheaper than the FEM for the same shape accuracy (the paper's low-cost claim)"
    rows = [r for r in a.reach if np.isfinite(r["ratio_fem_over_dr"])]
    missing = [f"{r['shape_error']:.1%}" for r in a.reach if not np.isfinite(r["ratio_fem_over_dr"])]
    if not rows:
        return Verdict(claim, "; ".join(f"{m} not reached" for m in missing) or "no speed runs", NOT_MEASURED)
    measured = "; ".join(f"{r['shape_error']:.1%} shape error: DR {r['time_dr']:.3g} s, FEM {r['time_fem']:.3g} s "
                         f"(FEM/DR {r['ratio_fem_over_dr']:.3g})" for r in rows)
    if missing:
        measured += f"; {', '.join(missing)} not reached by one of them"
    return Verdict(claim, measured, _held(sum(r["ratio_fem_over_dr"] > 1.0 for r in rows), len(rows), "accuracies"))


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
    return Verdict(claim, measured, _held(len(agree), len(rows), "levels"))


def model_form(a: Analysis) -> Verdict:
    """The paper's nets against the film they stand for: their limits against the triangles'."""
    claim = "The paper's nets (links, clustered) converge to the film's limit"
    lam = a.plan.speed_prestretch
    if not a.net_limits or a.dr_limit is None:
        return Verdict(claim, "no refined limits of the nets and the triangles", NOT_MEASURED)
    tri, tri_err = a.dr_limit.values["bending_angle"], a.dr_limit.errors["bending_angle"]
    parts, resolved = [], []
    for net, lim in a.net_limits.items():
        diff = lim.values["bending_angle"] - tri
        band = lim.errors["bending_angle"] + tri_err
        parts.append(f"{net} {diff:+.3g} +- {band:.2g} deg")
        if abs(diff) > band:
            resolved.append(f"{net} {diff:+.3g} deg")
    measured = f"limit minus the triangles' limit at lambda = {lam:g}: " + ", ".join(parts)
    verdict = (f"model-form error resolved: {', '.join(resolved)}" if resolved
               else "no model-form error beyond the refinement's error estimates")
    return Verdict(claim, measured, verdict)


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


def second_states(a: Analysis) -> Verdict:
    """The path's state against the states other starts reach."""
    claim = "The path's state is the lowest-energy state found"
    if not a.second_states:
        return Verdict(claim, "no search for other states", NOT_MEASURED)
    found = [r for r in a.second_states if r.get("second_state")]
    if not found:
        return Verdict(claim, f"no second stable state at {len(a.second_states)} pre-stretch levels", "holds")
    measured = "; ".join(f"{level_label(r['prestretch'])}: {r['theta_found']:.1f} deg, {r['energy_gap']:+.3g} N mm "
                         f"against the path's {r['theta_path']:.1f} deg" for r in found)
    lower = [level_label(r["prestretch"]) for r in found if r["energy_gap"] < 0.0]
    verdict = (f"does not hold at {', '.join(lower)}: a state of lower energy" if lower
               else "holds; other stable states exist, of higher energy")
    return Verdict(claim, measured, verdict)


CLAIMS: tuple[Callable[[Analysis], Verdict], ...] = (low_cost, one_problem, model_form, first_contact, second_states)
"""The validation's own claims, in the order of the table."""


def verdicts(a: Analysis) -> list[Verdict]:
    """The rows of the validation's own claims."""
    return [claim(a) for claim in CLAIMS]
