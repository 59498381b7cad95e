"""Progress reporting during a run and the final summary table (formatting only, no physics).

* On a terminal: one live line, rewritten in place (``\\r``) at most every 0.25 s: the sim
  time or load step, dt, steps per second, the relative energy balance and an ETA.
* Not on a terminal (CI logs, pipes, files): the same content as plain lines, one every
  ``[solve].progress_every`` seconds of wall time.
* ``quiet``: nothing but warnings and the final summary.

Everything printed is ASCII, so a log with a plain C locale never fails to encode it.
"""
from __future__ import annotations

import math
import shutil
import sys
import time

LIVE_EVERY = 0.25          # s between rewrites of the live line on a terminal


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def format_seconds(seconds: float | None) -> str:
    """``0:07``, ``12:34``, ``1:02:03``; ``3.0 d`` from a day; ``> 999 d`` beyond (an ETA
    early in a slow start can be absurdly long); ``--`` when unknown."""
    if seconds is None or not math.isfinite(seconds) or seconds < 0:
        return "--"
    if seconds >= 86400:
        days = seconds / 86400
        return f"{days:.1f} d" if days < 999.5 else "> 999 d"
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def format_rate(steps_per_second: float) -> str:
    if steps_per_second >= 1e6:
        return f"{steps_per_second / 1e6:.2f}M"
    if steps_per_second >= 1e3:
        return f"{steps_per_second / 1e3:.1f}k"
    return f"{steps_per_second:.0f}"


class Progress:
    """Live progress line (terminal) or periodic plain lines (otherwise)."""

    def __init__(self, quiet: bool = False, every: float = 2.0, stream=None, tty: bool | None = None):
        self.stream = stream if stream is not None else sys.stdout
        self.quiet = quiet
        self.tty = _is_tty(self.stream) if tty is None else tty
        self.every = LIVE_EVERY if self.tty else max(float(every), 0.0)
        self._live_width = 0
        self._last_show = time.perf_counter()
        self._t0 = self._last_show
        self._fraction0 = None
        self._last_step = None

    # -------------------------------------------------------------- plumbing
    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):      # closed pipe / stream: progress is not worth dying for
            pass

    def _clear_live(self) -> None:
        if self._live_width:
            self._write("\r" + " " * self._live_width + "\r")
            self._live_width = 0

    # -------------------------------------------------------------- public
    def start(self, step: int, fraction: float) -> None:
        """Baseline for steps/s and the ETA (the run may resume from a checkpoint)."""
        self._t0 = self._last_show = time.perf_counter()
        self._fraction0 = fraction
        self._last_step = step

    def due(self) -> bool:
        """True when a progress display is due (cheap; call after every batch)."""
        return not self.quiet and time.perf_counter() - self._last_show >= self.every

    def show(self, where: str, step: int, dt: float, balance: float | None, fraction: float | None) -> None:
        """Display the progress: `where` (load step or time), the step counter, dt, the
        relative energy balance and the completed `fraction` of the run (for the ETA)."""
        if self.quiet:
            return
        now = time.perf_counter()
        rate = None
        if self._last_step is not None and now > self._last_show:
            rate = (step - self._last_step) / (now - self._last_show)
        eta = None
        if fraction is not None and self._fraction0 is not None and fraction > self._fraction0:
            eta = (now - self._t0) * (1.0 - fraction) / (fraction - self._fraction0)
        self._last_show, self._last_step = now, step
        parts = [where, f"step {step}", f"dt {dt:.3e}"]
        if rate is not None:
            parts.append(f"{format_rate(rate)} steps/s")
        if balance is not None:
            parts.append(f"balance {balance:.1e}")
        parts.append(f"ETA {format_seconds(eta)}")
        line = "  ".join(parts)
        if self.tty:
            line = line[: max(20, shutil.get_terminal_size().columns - 1)]     # a wrapped line cannot be redrawn
            pad = max(0, self._live_width - len(line))
            self._write("\r" + line + " " * pad)
            self._live_width = len(line)
        else:
            self._write(line + "\n")

    def line(self, text: str) -> None:
        """A permanent line (e.g. a finished load step); suppressed when quiet."""
        if not self.quiet:
            self._clear_live()
            self._write(text + "\n")

    def warn(self, text: str) -> None:
        """A warning line: always shown, also when quiet."""
        self._clear_live()
        self._write(f"warning: {text}\n")

    def close(self) -> None:
        """Remove the live line (before the summary or an error message)."""
        self._clear_live()


# ------------------------------------------------------------------ final summary
def _num(v, fmt: str = ".4e") -> str:
    if v is None:
        return "-"
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    try:
        return format(v, fmt)
    except (TypeError, ValueError):
        return str(v)


def _pct(v) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{100 * v:.2f} %"


def summary_rows(summary: dict) -> list[tuple[str, str]]:
    """(label, value) rows of the final summary table."""
    rows = []
    steps = f"{summary.get('steps', 0):,}".replace(",", " ")
    if "load_steps" in summary:
        steps += f" in {summary['load_steps']} load steps"
    rows.append(("steps", steps))
    rows.append(("elements / nodes", f"{summary.get('elements', '-')} / {summary.get('nodes', '-')}"
                 f"  ({summary.get('method', '-')}, {summary.get('launch', '-')} on {summary.get('arch', '-')})"))
    rows.append(("compile / run", f"{_num(summary.get('compile_seconds'), '.1f')} s / "
                                  f"{_num(summary.get('run_seconds'), '.2f')} s"))
    rows.append(("us / element-step", _num(summary.get("us_per_element_step"), ".3f")))
    e = summary.get("energies") or {}
    for key, label in (("kinetic", "kinetic energy"), ("internal", "internal energy"),
                       ("hourglass", "hourglass energy"), ("drilling", "drilling energy"),
                       ("external_work", "external work"), ("motion_work", "motion work"),
                       ("damped", "damped energy"), ("eroded", "eroded energy"),
                       ("mass_scaling", "mass scaling energy"), ("balance_error", "balance error")):
        if key in e and (key not in ("damped", "motion_work", "eroded", "mass_scaling") or e[key]):
            rows.append((label, _num(e[key])))
    for b in summary.get("rigid_bodies", []):
        force = ", ".join(_num(c) for c in b["force"])
        moment = f"; moment [{', '.join(_num(c) for c in b['moment'])}]" if b["moment"] is not None else ""
        rows.append((f"body {b['name']}", f"kinetic {_num(b['kinetic_energy'])}; force [{force}]{moment}"))
    for m in summary.get("motions", []):
        reaction = ", ".join(f"{d} {_num(v)}" for d, v in m["reaction"].items())
        rows.append((f"motion {m['name']}", f"reaction {reaction}; work {_num(m['work'])}"))
    if "erosion" in summary:
        rows.append(("eroded elements", f"{summary['erosion']['eroded_elements']}"))
    if "mass_scaling" in summary:
        ms = summary["mass_scaling"]
        rows.append(("target step", f"{_num(ms['target_dt'])}" + (' ("auto")' if ms.get("target_dt_auto") else "")))
        if "solve" in ms:
            rows.append(("selective mass scaling", f"{ms['scaled_elements']} elements, deformation modes +"
                                                   f"{ms['deformation_mass_percent']:.3g} % of the shell's mass, "
                                                   + ("reciprocal mass matrix (no solve)"
                                                      if ms["solve"].get("form") == "reciprocal" else
                                                      f"{ms['solve']['iterations_mean']:.3g} iterations per step "
                                                      f"(max {ms['solve']['iterations_max']})")))
        else:
            rows.append(("added mass", f"{_num(ms['added_mass'])} ({ms['added_mass_percent']:.3g} % of the shell, "
                                       f"{ms['scaled_elements']} elements)"))
    parts = [p for p in summary.get("parts", []) if "material" in p]
    if len(parts) > 1:
        for p in parts:
            pe, (t0, t1) = p["energies"], p["thickness"]
            t = _num(t0, ".4g") if t0 == t1 else f"{_num(t0, '.4g')}-{_num(t1, '.4g')}"
            rows.append((f"part {p['name']}", f"{p['elements']} el, t {t}: internal {_num(pe['internal'])}, "
                         f"plastic {_num(pe['plastic_work'])}, hourglass {_num(pe['hourglass'])}, "
                         f"kinetic {_num(pe['kinetic'])}"))
    ref = summary.get("reference")
    if ref:
        for col, r in ref.get("columns", {}).items():
            rows.append((f"vs reference {col}", f"mean {_pct(r.get('mean_rel_error'))}  "
                                               f"max {_pct(r.get('max_rel_error'))}"))
        if ref.get("missing_levels"):
            rows.append(("reference rows missed", str(len(ref["missing_levels"]))))
    crush = summary.get("crush")
    if crush:
        rows.append(("crush distance", _num(crush.get("crush_distance"), ".2f")))
        rows.append(("peak support force", _num(crush.get("peak_support_force"), ".3f")))
        rows.append(("mean crush force", _num(crush.get("mean_crush_force"), ".3f")
                     + f"  (window {crush.get('mean_force_window')})"))
        rows.append(("folds (lobes)", f"{crush.get('folds', '-')}"))
        rows.append(("fold half-wavelength", _num(crush.get("half_wavelength"), ".2f")))
        rows.append(("energy balance error", _pct(crush.get("energy_balance_error_max"))))
        rows.append(("hourglass / internal", _pct(crush.get("hourglass_over_internal"))))
    for w in summary.get("warnings", []):
        rows.append(("warning", w))
    if summary.get("error"):
        rows.append(("stopped", summary["error"]))
    return rows


def format_summary(summary: dict) -> str:
    """The final summary as a small two-column table."""
    rows = summary_rows(summary)
    width = max(len(label) for label, _ in rows)
    title = f"summary: {summary.get('scene', '')}"
    rule = "-" * max(len(title), width + 30)
    lines = [title, rule] + [f"{label:<{width}}  {value}" for label, value in rows] + [rule]
    return "\n".join(lines)
