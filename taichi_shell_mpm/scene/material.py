"""[material] and [materials.NAME]: the material models of laws/ (elastic, j2 with its hardening,
rate and failure laws, orthotropic with its own table, hill48), their keys and rules."""
from __future__ import annotations

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
from ..laws.orthotropic import OrthotropicMaterial
from ..laws.rate import LAWS as RATE
from ..laws.rate import OPTIONAL as RATE_OPTIONAL
from .reader import Reader

MATERIAL_MODELS = tuple(LAWS)
"""Every material model (laws/<model>.py; some with keys of their own below)."""
LAW_KEYS = {name: law.KEYS for name, law in LAWS.items()}
MODEL_KEYS = {name: k for keys in LAW_KEYS.values() for name, k in keys.items()}
"""Every model's own keys (hill48's r-values), one dict: read with [material]'s."""


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
        doc="; ".join(law.DOC for law in LAWS.values()))
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


AnyMaterial = Union[Material, OrthotropicMaterial]


def read_material(r: Reader, path: str, data: Any) -> AnyMaterial | None:
    """[material] or [materials.NAME]: an orthotropic material, or its keys, then those of
    its hardening and rate laws (each law takes its own keys: a key of another law is an
    error)."""
    own = LAWS.get(data.get("model")) if isinstance(data, dict) and isinstance(data.get("model"), str) else None
    if own is not None and own.TABLE is not None:       # a model with a table of its own (orthotropic)
        material = r.table_object(path, data, own.TABLE)
        return None if material is None else own.check(r, path, material)
    mark = len(r.messages)
    values = r.read(path, data, {**keys_of(Material), **MODEL_KEYS}, Material)
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


