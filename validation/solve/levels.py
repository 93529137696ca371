"""Run a pre-stretch sweep of any solver and write its table, CSV, VTK states and .pvd series."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from tqdm import tqdm

from results import SUMMARY_COLUMNS, Result, level_label, write_pvd

from ..common.tables import STATE_TABLE, format_table, write_csv


def record_states(
    states: Iterator[Result],
    prestretches: Sequence[float],
    out_dir: str | Path,
    label: str,
    progress: bool = True,
    on_state: Callable[[Result], None] | None = None,
    extra: Callable[[Result], dict[str, Any]] | None = None,
    units: dict[str, str] | None = None,
) -> list[Result]:
    """Consume a solver's sweep, writing each finished state at once.

    Each state goes to ``out_dir/label_<prestretch>.vtu``; ``label.csv`` and ``label.pvd`` are
    rewritten (atomically) after every state, so an interrupted sweep keeps what it finished.
    ``extra(state)`` gives further CSV columns (after the summary's), with ``units``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: list[Result] = []
    entries: list[tuple[float, Path]] = []
    bar = tqdm(total=len(prestretches), desc=label, unit="state", disable=not progress, leave=False)
    try:
        for res in states:
            vtu = res.write_vtk(out / f"{label}_{level_label(res.prestretch)}.vtu")
            entries.append((res.prestretch, vtu))
            results.append(res)
            write_pvd(out / f"{label}.pvd", entries)
            rows = [{**r.summary(), **(extra(r) if extra else {})} for r in results]
            columns = [c for c, _ in SUMMARY_COLUMNS] + [c for c in rows[0] if c not in dict(SUMMARY_COLUMNS)]
            write_csv(out / f"{label}.csv", rows, columns, units)
            bar.set_postfix_str(f"lambda={level_label(res.prestretch)} theta={res.summary()['bending_angle']:.1f} {res.status}")
            bar.update()
            if on_state is not None:
                on_state(res)
    finally:
        bar.close()
    return results


def print_table(results: Sequence[Result], title: str = "", columns: Sequence[tuple[str, str, str]] = STATE_TABLE,
                extra: Callable[[Result], dict[str, Any]] | None = None) -> str:
    """The state table (as printed by ``demes fem``; ``demes solve`` adds the mesh error with
    ``extra``), returned and printed."""
    rows = [{**r.summary(), **(extra(r) if extra else {})} for r in results]
    for row in rows:  # a word where the angle cannot be read, not a blank
        if row.get("angle_unreadable"):
            row["bending_angle"] = "unreadable"
    text = format_table(rows, columns)
    if title:
        text = f"{title}\n{text}"
    print(text, flush=True)
    return text


def contact_note(results: Sequence[Result]) -> str:
    """One line if any state was solved without contact checks, printed and returned."""
    if not any(r.info.get("contact_checked") is False for r in results):
        return ""
    line = ("  contact checks were off (dr.check_contact = false): the frame and film were free to pass "
            "through themselves; states where they did read 'unreadable'")
    print(line, flush=True)
    return "\n" + line


def state_notes(results: Sequence[Result], requested: Sequence[float]) -> str:
    """What a reader of the table needs beside its numbers: each converged state's remarks
    (:attr:`results.Result.remarks`: jumps, an apex against the lift, a curl past half a turn,
    a lower state found), why each stopped state stopped, and the requested pre-stretches the
    path did not reach; printed under the table and returned."""
    lines = [f"  {r.status}: {r.message}" if not r.converged else f"  {level_label(r.prestretch)}: " + "; ".join(r.remarks)
             for r in results if not r.converged or r.remarks]
    missed = not_reached(requested, [r.prestretch for r in results])
    if missed:
        lines.append("  not reached (the path stopped before them): " + " ".join(level_label(v) for v in missed))
    text = "\n" + "\n".join(lines) if lines else ""
    if text:
        print(text.lstrip("\n"), flush=True)
    return text


def not_reached(requested: Sequence[float], solved: Sequence[float]) -> list[float]:
    """The requested pre-stretches above the highest one a path got to (it stopped before)."""
    reached = max(solved, default=0.0)
    return [lam for lam in requested if lam > reached + 1e-9]
