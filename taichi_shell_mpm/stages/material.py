"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material model (laws/<model>.py: elastic, j2, orthotropic, hill48) is a small class with a
``ti.func`` ``update(row, axes, stress,
plastic_strain, strain_rate, strain_increment, shear_increment, dt)`` that reads its
parameters from ``row``, the point's material's row of the material table
(state.sections.material, columns in model/materials.py); ``axes`` = (cos, sin) of the angle from
the element's e1 to the point's material 1-axis, which the oriented models read (orthotropic,
hill48; docs/laminates.md).  :class:`ConstitutiveUpdate` dispatches each point to its material's
model with a ``ti.static`` loop over the models the scene uses (Features.materials), so only
those are compiled [choice, issue 17, as Genesis's MPM solver dispatches its materials]; parameter
values are run-time data (a changed E or yield stress loads the kernels from the cache).
The J2 model's flow stress sigma_y(ebar) R(rate) dispatches the same way over the hardening
and rate laws the scene uses (Features.hardening, Features.rate_laws; one file each in
laws/hardening/ and laws/rate/): the laws' parameters, the tabulated curves included, are
run-time data too.
"""

from types import SimpleNamespace

import taichi as ti

from ..laws import MODELS as MODEL_FILES
from ..laws.hardening import LAWS as HARDENING_LAWS
from ..laws.rate import LAWS as RATE_LAWS
from ..model.materials import BLOCK_OFFSET, COL, ORIENTED

# ---------------------------------------------------------------- flow-stress laws (laws/hardening/, laws/rate/)
_SHARED = {name: COL[name] for name in ("yield_stress", "hardening")}
HARDENING = {name: law.kernel(COL["hardening_0"], _SHARED) for name, law in HARDENING_LAWS.items()}
"""sigma_y(ebar) of each hardening law (materials.HARDENING_LAWS)."""
RATE = {name: law.kernel(COL["rate_0"]) for name, law in RATE_LAWS.items()}
"""R(rate) of each rate law (materials.RATE_LAWS)."""


def _models() -> dict:
    """Every material model's point update (laws/<model>.py), built in the registry's order:
    a model may extend one built before it (j2 extends elastic, hill48 j2)."""
    context = SimpleNamespace(col=COL, block_offset=BLOCK_OFFSET, hardening_kernels=HARDENING,
                              rate_kernels=RATE, models={})
    for name, model in MODEL_FILES.items():
        context.models[name] = model.kernel(context)
    return context.models


MODELS = _models()
"""Every model, materials.KINDS."""
PlaneStressElastic, PlaneStressJ2, PlaneStressOrthotropic = MODELS["elastic"], MODELS["j2"], MODELS["orthotropic"]


@ti.data_oriented
class ConstitutiveUpdate:
    """The point update of the scene's materials: ``update(kind, row, axes, ...)`` runs the
    model `kind` (state.sections.material_kind of the point's material, an index into
    Features.materials); only the models the scene uses are compiled.  It keeps the point's
    filtered strain rate (state.points.strain_rate) when a material filters it."""

    def __init__(self, state, kinds: tuple[str, ...]):
        self.s = state
        self.models = tuple(MODELS[k](state) for k in kinds)
        self.plastic = any(m.plastic for m in self.models)
        self.rate_filter = state.features.rate_filter
        self.oriented = any(ORIENTED[k] for k in kinds)

    @ti.func
    def row(self, material):
        out = ti.Vector.zero(ti.f64, ti.static(self.s.sections.material.shape[1]))
        for j in ti.static(range(self.s.sections.material.shape[1])):
            out[j] = self.s.sections.material[material, j]
        return out

    @ti.func
    def kind(self, material):
        return self.s.sections.material_kind[material]

    @ti.func
    def point_material(self, section, k):
        """Model index and parameter row of the material of point k of `section`."""
        material = self.s.sections.point_material[section, k]
        return self.kind(material), self.row(material)

    @ti.func
    def axes(self, e, section, k):
        """(cos, sin) of the angle from element e's e1 to the material 1-axis at its point k:
        the element's material axis turned by the point's ply angle; (1, 0) when no material
        of the scene has axes (nothing is read)."""
        out = ti.Vector([1.0, 0.0])
        if ti.static(self.oriented):
            a, p = self.s.sections.material_axis[e], self.s.sections.ply_axis[section, k]
            out = ti.Vector([a[0] * p[0] - a[1] * p[1], a[1] * p[0] + a[0] * p[1]])
        return out

    @ti.func
    def update(self, kind, row, axes, stress, plastic_strain, d_strain, d_shear, dt, e, k):
        """The update of the model `kind` (index into Features.materials) with parameters `row`
        at point k of element e over the step dt."""
        rate = 0.0
        if ti.static(self.rate_filter):
            rate = self.s.points.strain_rate[e, k]
        new, ebar, work, converged = stress, plastic_strain, 0.0, True
        if ti.static(len(self.models) == 1):
            new, ebar, rate, work, converged = self.models[0].update(row, axes, stress, plastic_strain, rate,
                                                                     d_strain, d_shear, dt)
        else:
            for i, model in ti.static(enumerate(self.models)):
                if kind == i:
                    new, ebar, rate, work, converged = model.update(row, axes, stress, plastic_strain, rate,
                                                                    d_strain, d_shear, dt)
        if ti.static(self.rate_filter):
            self.s.points.strain_rate[e, k] = rate
        return new, ebar, work, converged
