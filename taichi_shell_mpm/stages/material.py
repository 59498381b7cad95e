"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material is a small class with a ``ti.func`` ``update(stress, strain_increment,
shear_increment)``; the shell stage calls the scene's material through ``ti.static``
so only that material is compiled.
"""

import taichi as ti


def make_material(spec):
    """The material class for a scene's [material] table (registry by `model`)."""
    if spec.model == "j2":
        return PlaneStressJ2(spec.E, spec.nu, spec.yield_stress, spec.hardening)
    return PlaneStressElastic(spec.E, spec.nu)


@ti.data_oriented
class PlaneStressElastic:
    """Linear elastic, plane stress in plane, elastic transverse shear (tau += G dgamma;
    the shear factor is applied on the resultants, method.md 3.4-3.5)."""

    plastic = False

    def __init__(self, E: float, nu: float):
        self.c11 = E / (1.0 - nu * nu)
        self.c12 = nu * self.c11
        self.c33 = E / (2.0 * (1.0 + nu))

    @ti.func
    def update(self, stress, plastic_strain, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, plastic work per unit volume)."""
        new = stress + ti.Vector([
            self.c11 * d_strain[0] + self.c12 * d_strain[1],
            self.c12 * d_strain[0] + self.c11 * d_strain[1],
            self.c33 * d_strain[2],
            self.c33 * d_shear[0],
            self.c33 * d_shear[1]])
        return new, plastic_strain, 0.0


@ti.data_oriented
class PlaneStressJ2(PlaneStressElastic):
    """von Mises plasticity in plane stress with linear isotropic hardening: elastic
    predictor, plane-stress return map (method.md 3.4).  Transverse shear stays elastic."""
    plastic = True

    def __init__(self, E: float, nu: float, yield_stress: float, hardening: float):
        super().__init__(E, nu)
        self.yield_stress = yield_stress
        self.hardening = hardening

    @ti.func
    def update(self, stress, plastic_strain, d_strain, d_shear):
        trial, _, _ = PlaneStressElastic.update(self, stress, plastic_strain, d_strain, d_shear)
        return trial, plastic_strain, 0.0   # TODO(helper): plane-stress return
