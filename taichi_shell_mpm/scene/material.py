"""[material] and [materials.NAME]: elastic, j2 (with its hardening, rate and failure laws) and orthotropic materials."""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Union

from ..keys import (
    Check,
    Invalid,
    choice,
    curve_points,
    hardening_curve,
    integer,
    key,
    key_path,
    keys_of,
    non_negative,
    number,
    one_line,
    positive,
    show,
)
from ..laws import MODELS as LAWS
from .reader import Reader

MATERIAL_MODELS = ("elastic", "j2", "orthotropic", *LAWS)
"""The built-in models and the plug-in ones (laws/: their own keys below)."""
LAW_KEYS = {name: law.KEYS for name, law in LAWS.items()}


HARDENING_KEYS = {"linear": (("yield_stress",), ("hardening",)),
                   "swift": (("K", "n"), ("eps0", "yield_stress", "hardening")),
                   "ludwik": (("yield_stress", "B", "n"), ("max_stress", "hardening")),
                   "voce": (("yield_stress", "Q", "b"), ("hardening",)),
                   "tabulated": ((), ("curve", "curve_file", "beyond_curve"))}


RATE_KEYS = {"none": ((), ()), "cowper_symonds": (("C", "p"), ("rate_measure", "rate_filter_time",
                                                                  "rate_cutoff_frequency")),
              "johnson_cook": (("c", "reference_rate"), ("rate_measure", "rate_filter_time",
                                                          "rate_cutoff_frequency"))}


def read_curve_file(r: Reader, value: Any) -> tuple[Path, tuple[tuple[float, float], ...]]:
    """A CSV file of (plastic strain, yield stress) rows, relative to the scene file (an
    optional header row; blank lines and lines starting with '#' are skipped): its path
    and points (curve_points)."""
    path = r.file(value)
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = [(i, row) for i, row in enumerate(csv.reader(f), 1)
                    if row and "".join(row).strip() and not row[0].lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise Invalid(f"cannot read {path.name} ({one_line(exc)})")

    def number(text: str) -> float | None:
        try:
            x = float(text)
        except ValueError:
            return None
        return x if math.isfinite(x) else None
    if rows and any(number(cell) is None for cell in rows[0][1]):
        rows = rows[1:]                           # the header
    points, lines = [], []
    for line, row in rows:
        cells = [number(cell) for cell in row]
        if len(cells) != 2 or None in cells:
            raise Invalid(f"{path.name} line {line}: expected two numbers (plastic strain, yield stress), "
                           f"got {show(','.join(row))}")
        points.append((cells[0], cells[1]))
        lines.append(line)
    return path, curve_points(points, lambda i: f"{path.name} line {lines[i]}")


curve_file = Check(None, "string", "an existing file", {"type": "string"}, context=read_curve_file)
"""The CSV file of a tabulated hardening curve (read_curve_file)."""


@dataclass(frozen=True)
class Material:
    E: float = key(positive, "Young's modulus", unit="stress")
    nu: float = key(number(-1, 0.5, lo_open=True, hi_open=True), "Poisson's ratio")
    density: float = key(positive, unit="mass/length³",
        doc="mass density (per volume); fictitious in static solves, ρ = 1 is fine")
    model: str = key(
        choice(*MATERIAL_MODELS), default="elastic",
        doc="`elastic`: linear, in the element's corotational frame; `j2`: von Mises plasticity in plane stress "
            "with isotropic hardening, flow stress σ_f = σ_y(ε̄ᵖ) R(ε̇) of the hardening and rate laws below "
            "(consistent plane-stress return map, method.md 3.4; a return that does not converge stops the run "
            "naming the element); `orthotropic`: the keys of the orthotropic table below instead of `E`, `nu`; "
            + "; ".join(law.DOC for law in LAWS.values()))
    yield_stress: float = key(
        positive, default=0.0, unit="stress", default_text="required for `linear`, `ludwik`, `voce`",
        doc="initial yield stress σ_y0 (Ludwik's A; `swift`: instead of `eps0`, which is then (σ_y0/K)^(1/n))")
    hardening: float = key(non_negative, default=0.0, unit="stress",
        doc="linear hardening modulus H: the `linear` law, and a linear term of `swift`, `ludwik` and `voce` (0 ="
            " none; `linear` with 0 is perfectly plastic)")
    hardening_law: Literal["linear", "swift", "ludwik", "voce", "tabulated"] = key(
        choice("linear", "swift", "ludwik", "voce", "tabulated"), default="linear",
        doc="σ_y(ε̄ᵖ), each law with its own keys (a key of another law is an error): `linear` σ_y0 + H ε̄ᵖ "
            "(`yield_stress`, `hardening`); `swift` K (ε₀ + ε̄ᵖ)ⁿ + H ε̄ᵖ (`K`, `n`, and `eps0` or "
            "`yield_stress`, `hardening`); `ludwik` σ_y0 + B (ε̄ᵖ)ⁿ + H ε̄ᵖ, Johnson–Cook's strain term, capped "
            "at `max_stress` when given (`yield_stress` = A, `B`, `n`, `hardening`, `max_stress`); `voce` σ_y0 + "
            "Q (1 − e^(−b ε̄ᵖ)) + H ε̄ᵖ (`yield_stress`, `Q`, `b`, `hardening`); `tabulated` linear between the "
            "points of `curve` or `curve_file`, beyond the last as `beyond_curve` says")
    K: float = key(positive, default=0.0, unit="stress", default_text="required for `swift`",
        doc="Swift's strength coefficient")
    eps0: float = key(positive, default=0.0, default_text="`swift`: this or `yield_stress`",
        doc="Swift's prestrain ε₀ (the initial yield stress is K ε₀ⁿ)")
    n: float = key(positive, default=0.0, default_text="required for `swift`, `ludwik`",
        doc="hardening exponent; `ludwik` with n < 1 has an infinite slope at ε̄ᵖ = 0, which the return handles "
            "(method below)")
    B: float = key(non_negative, default=0.0, unit="stress", default_text="required for `ludwik`",
        doc="Ludwik's (Johnson–Cook's) hardening coefficient")
    max_stress: float | None = key(positive, default=None, unit="stress", allowed="> `yield_stress`",
        doc="`ludwik`: σ_y is capped here")
    Q: float = key(non_negative, default=0.0, unit="stress", default_text="required for `voce`",
        doc="Voce's saturation stress increase")
    b: float = key(non_negative, default=0.0, default_text="required for `voce`",
        doc="Voce's saturation rate (1 / strain)")
    curve: tuple[tuple[float, float], ...] = key(hardening_curve, default=(), default_text="–",
        doc="`tabulated`: the points, e.g. `[[0.0, 0.25], [0.05, 0.31], [0.2, 0.38]]`")
    curve_file: Path | None = key(curve_file, default=None, default_text="–",
        doc="`tabulated`: a CSV file of `ε̄ᵖ, σ_y` rows (relative to the scene file; an optional header row; "
            "blank lines and lines starting with `#` skipped); exactly one of `curve` and `curve_file`")
    beyond_curve: Literal["flat", "extrapolate"] = key(choice("flat", "extrapolate"), default="flat",
        doc="beyond the last point: its stress, or the last segment's line (needs two points)")
    rate_law: Literal["none", "cowper_symonds", "johnson_cook"] = key(
        choice("none", "cowper_symonds", "johnson_cook"), default="none",
        doc="strain-rate factor R(ε̇) on any hardening law (`model = \"j2\"`, dynamic solves): `cowper_symonds` 1 +"
            " (ε̇/C)^(1/p); `johnson_cook` 1 + c ln(ε̇/ε̇₀), not below 1 (so rates at or under ε̇₀, and a zero "
            "rate, give the rate-free answer exactly)")
    C: float = key(positive, default=0.0, unit="1/time", default_text="required for `cowper_symonds`",
        doc="Cowper–Symonds rate constant, 1/time in the scene's units (D = 40.4 /s is 0.0404 /ms in kN-mm-ms)")
    p: float = key(positive, default=0.0, default_text="required for `cowper_symonds`",
        doc="Cowper–Symonds exponent (q = 5 for mild steel)")
    c: float = key(non_negative, default=0.0, default_text="required for `johnson_cook`",
        doc="Johnson–Cook rate coefficient")
    reference_rate: float = key(positive, default=0.0, unit="1/time", default_text="required for `johnson_cook`",
        doc="ε̇₀, 1/time")
    rate_measure: Literal["total", "plastic"] = key(choice("total", "plastic"), default="total",
        doc="the rate ε̇: the effective total strain rate of the step (LS-DYNA VP = 0), or the equivalent plastic"
            " strain rate (VP = 1, solved in the return map)")
    rate_filter_time: float = key(positive, default=0.0, unit="time", default_text="none (unfiltered)",
        doc="time constant τ of an exponential filter of the rate, ε̇_f ← α ε̇ + (1 − α) ε̇_f with α = 1 − "
            "e^(−Δt/τ) (the filtered rate is kept per through-thickness point)")
    rate_cutoff_frequency: float = key(positive, default=0.0, unit="1/time", default_text="none",
        doc="the filter given by its cutoff frequency f_c (1/time): τ = 1/(2π f_c); not with `rate_filter_time`")
    failure_strain: float = key(positive, default=0.0, default_text="none (no failure)",
        doc="erosion (`model = \"j2\"`, dynamic solves; LS-DYNA FAIL): an element fails in the step in which "
            "`failure_points` of its through-thickness points reach this equivalent plastic strain")
    failure_points: int = key(
        integer(1, 10), default=1, allowed="1 .. the points of every section the material is used with; only with `failure_strain`",
        doc="how many through-thickness points must reach `failure_strain` (LS-DYNA NUMFIP)")
    failure_min_dt: float = key(positive, default=0.0, unit="time", default_text="none",
        doc="erosion (any model, dynamic solves; LS-DYNA TDEL): an element also fails once its stable time step "
            "(after mass scaling) falls below this")
    model_parameters: tuple[tuple[str, float], ...] = ()
    """A plug-in model's own keys (laws/<model>.py KEYS) with their values, defaults filled in."""

    @property
    def parameters(self) -> dict[str, float]:
        return dict(self.model_parameters)


@dataclass(frozen=True)
class OrthotropicMaterial:
    """Linear elastic, orthotropic in plane stress with its own transverse shear moduli
    (docs/laminates.md): 1 = the fibre direction, 2 = across it in the shell's plane,
    3 = the shell normal.  Its axes are the section's material axes turned by the ply angle."""
    E1: float = key(positive, "Young's modulus along the fibres (axis 1)", unit="stress")
    E2: float = key(positive, "Young's modulus across the fibres in the shell plane (axis 2)", unit="stress")
    G12: float = key(positive, "in-plane shear modulus", unit="stress")
    G13: float = key(positive, "transverse shear modulus in the 1-3 plane (3 = the shell normal)", unit="stress")
    G23: float = key(positive, "transverse shear modulus in the 2-3 plane", unit="stress")
    nu12: float = key(number(), allowed="|nu12| < √(E1/E2)",
        doc="major Poisson ratio: ε₂ = −ν₁₂ σ₁/E₁ (ν₂₁ = ν₁₂E₂/E₁); the bound keeps the plane-stress stiffness "
            "positive definite")
    density: float = key(positive, "mass density", unit="mass/length³")
    model: Literal["orthotropic"] = key(choice(*MATERIAL_MODELS), "`orthotropic`: this table's keys", default="orthotropic")


AnyMaterial = Union[Material, OrthotropicMaterial]


def read_material(r: Reader, path: str, data: Any) -> AnyMaterial | None:
    """[material] or [materials.NAME]: an orthotropic material, or its keys, then those of
    its hardening and rate laws (each law takes its own keys: a key of another law is an
    error)."""
    if isinstance(data, dict) and data.get("model") == "orthotropic":
        material = r.table_object(path, data, OrthotropicMaterial)
        if material is not None and material.nu12 ** 2 >= material.E1 / material.E2:
            r.error(f"{path}.nu12", f"expected |nu12| < sqrt(E1/E2) = {math.sqrt(material.E1 / material.E2):g} "
                                       f"(a positive definite plane-stress stiffness), got {material.nu12:g}")
            return None
        return material
    mark = len(r.messages)
    law_keys = {name: k for keys in LAW_KEYS.values() for name, k in keys.items()}
    values = r.read(path, data, {**keys_of(Material), **law_keys}, Material)
    if values is None:
        return None
    for name, declared in LAW_KEYS.items():      # a plug-in model's keys: with it only
        given = {n: values.pop(n) for n in declared if n in values}
        for n in declared:
            if n in data and "model" in values and values["model"] != name:
                r.error(f"{path}.{n}", f'only for model = "{name}"')
        if values.get("model") == name:
            values["model_parameters"] = tuple((n, given.get(n, k.default)) for n, k in declared.items())
    plasticity = {k for table in (HARDENING_KEYS, RATE_KEYS) for keys in table.values() for group in keys
                  for k in group} | {"hardening_law", "rate_law"}
    if values.get("model") == "elastic":
        for key in data:
            if key in plasticity - {"yield_stress", "hardening"}:
                r.error(f"{path}.{key_path(key)}", "only for model = \"j2\"")
    elif "model" in values:
        for key, table in (("hardening_law", HARDENING_KEYS), ("rate_law", RATE_KEYS)):
            if key in values:
                check_law_keys(r, path, data, key, values[key], table)
        if values.get("hardening_law") == "swift":
            if ("eps0" in data) == ("yield_stress" in data):
                r.error(f"{path}.eps0", "expected exactly one of eps0 and yield_stress for hardening_law = "
                                           "\"swift\" (yield_stress sets eps0 = (yield_stress / K)^(1/n))")
            elif all(k in data and k in values for k in ("yield_stress", "K", "n")):
                values["eps0"] = (values["yield_stress"] / values["K"]) ** (1.0 / values["n"])
        if values.get("hardening_law") == "tabulated" and ("curve" in data) == ("curve_file" in data):
            r.error(f"{path}.curve", "expected exactly one of curve and curve_file for "
                                        "hardening_law = \"tabulated\"")
        if "curve_file" in data and "curve_file" in values:
            values["curve_file"], values["curve"] = values["curve_file"]
        if values.get("beyond_curve") == "extrapolate" and 0 < len(values.get("curve", ())) < 2:
            r.error(f"{path}.beyond_curve", "\"extrapolate\" needs a curve of at least two points")
        cap, sy = values.get("max_stress"), values.get("yield_stress")
        if "max_stress" in data and "yield_stress" in data and cap is not None and sy is not None and cap <= sy:
            r.error(f"{path}.max_stress", f"expected a number above yield_stress = {sy:g}, got {cap:g}")
        if "rate_filter_time" in data and "rate_cutoff_frequency" in data:
            r.error(f"{path}.rate_cutoff_frequency", "give the rate filter either as rate_filter_time or "
                                                        "as rate_cutoff_frequency, not both")
    if "failure_strain" in data and values.get("model") == "elastic":
        r.error(f"{path}.failure_strain", "only for model = \"j2\" (the equivalent plastic strain); "
                                             "failure_min_dt erodes elements of any model")
    if "failure_points" in data and "failure_strain" not in data:
        r.error(f"{path}.failure_points", "only with failure_strain")
    return r.build(mark, Material, values)


def check_law_keys(r: Reader, path: str, data: dict, key: str, law: str, table: dict) -> None:
    """Report the keys of `table`'s other laws given with `key` = `law`, and its missing ones."""
    required, optional = table[law]
    own = (*required, *optional)
    for name in data:
        if any(name in group for keys in table.values() for group in keys) and name not in own:
            r.error(f"{path}.{key_path(name)}", f"not used by {key} = \"{law}\""
                       + (f" (its keys: {', '.join(own)})" if own else ""))
    for name in required:
        if name not in data:
            r.error(f"{path}.{name}", "missing required key for model = \"j2\"" if key not in data else
                       f"missing required key for {key} = \"{law}\"")


