"""[material] and [materials.NAME]: elastic, j2 (with its hardening, rate and failure laws) and orthotropic materials."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Union

from ..keys import (
    choice,
    extended,
    key,
    key_path,
    keys_of,
    non_negative,
    number,
    positive,
)
from ..laws import MODELS as LAWS
from ..laws.failure import CRITERIA as FAILURE
from ..laws.hardening import LAWS as HARDENING
from ..laws.rate import LAWS as RATE
from ..laws.rate import OPTIONAL as RATE_OPTIONAL
from .reader import Reader

MATERIAL_MODELS = ("elastic", "j2", "orthotropic", *LAWS)
"""The built-in models and the plug-in ones (laws/: their own keys below)."""
LAW_KEYS = {name: law.KEYS for name, law in LAWS.items()}


HARDENING_KEYS = {name: (law.REQUIRED, law.OPTIONAL) for name, law in HARDENING.items()}
"""The keys of each hardening law: (required, optional); a key of another law is an error."""
RATE_KEYS = {"none": ((), ()), **{name: (law.REQUIRED, RATE_OPTIONAL) for name, law in RATE.items()}}


@dataclass(frozen=True)
class MaterialKeys:
    """The keys of [material] that every elastic or plastic material has; Material adds those
    of the hardening and rate laws and the failure criteria, declared in their files
    (laws/hardening/, laws/rate/, laws/failure/)."""
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
    hardening_law: str = key(
        choice(*HARDENING), default="linear",
        doc="σ_y(ε̄ᵖ), each law with its own keys (a key of another law is an error; laws/hardening/): "
            + "; ".join(law.DOC for law in HARDENING.values()))
    rate_law: str = key(
        choice("none", *RATE), default="none",
        doc="strain-rate factor R(ε̇) on any hardening law (a plastic model, dynamic solves; laws/rate/): "
            + "; ".join(law.DOC for law in RATE.values()))
    rate_measure: Literal["total", "plastic"] = key(choice("total", "plastic"), default="total",
        doc="the rate ε̇: the effective total strain rate of the step (LS-DYNA VP = 0), or the equivalent plastic"
            " strain rate (VP = 1, solved in the return map)")
    rate_filter_time: float = key(positive, default=0.0, unit="time", default_text="none (unfiltered)",
        doc="time constant τ of an exponential filter of the rate, ε̇_f ← α ε̇ + (1 − α) ε̇_f with α = 1 − "
            "e^(−Δt/τ) (the filtered rate is kept per through-thickness point)")
    rate_cutoff_frequency: float = key(positive, default=0.0, unit="1/time", default_text="none",
        doc="the filter given by its cutoff frequency f_c (1/time): τ = 1/(2π f_c); not with `rate_filter_time`")
    model_parameters: tuple[tuple[str, float], ...] = ()
    """A plug-in model's own keys (laws/<model>.py KEYS) with their values, defaults filled in."""

    @property
    def parameters(self) -> dict[str, float]:
        return dict(self.model_parameters)


Material = extended(MaterialKeys, "Material", __name__,
                    {n: k for law in (*HARDENING.values(), *RATE.values(), *FAILURE.values())
                     for n, k in law.KEYS.items()},
                    "A material of [material] / [materials.NAME]: MaterialKeys and the keys of the hardening and "
                    "rate laws and the failure criteria, each declared in its file (laws/).")


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
        law = HARDENING.get(values.get("hardening_law"))
        if law is not None and hasattr(law, "rules"):           # the law's own rules across keys
            law.rules(r, path, data, values)
        if "rate_filter_time" in data and "rate_cutoff_frequency" in data:
            r.error(f"{path}.rate_cutoff_frequency", "give the rate filter either as rate_filter_time or "
                                                     "as rate_cutoff_frequency, not both")
    for criterion in FAILURE.values():            # the failure criteria's rules (laws/failure/)
        if hasattr(criterion, "rules"):
            criterion.rules(r, path, data, values)
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


