"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material is a small class with a ``ti.func`` ``update(stress, strain_increment,
shear_increment)``; the shell stage calls the scene's material through ``ti.static``
so only that material is compiled.
"""

import taichi as ti


@ti.data_oriented
class PlaneStressElastic:
    """Linear elastic, plane stress in plane, elastic transverse shear (tau += G dgamma;
    the shear factor is applied on the resultants, method.md 3.4-3.5)."""

    def __init__(self, E: float, nu: float):
        self.c11 = E / (1.0 - nu * nu)
        self.c12 = nu * self.c11
        self.c33 = E / (2.0 * (1.0 + nu))

    @ti.func
    def update(self, stress, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz)."""
        return stress + ti.Vector([
            self.c11 * d_strain[0] + self.c12 * d_strain[1],
            self.c12 * d_strain[0] + self.c11 * d_strain[1],
            self.c33 * d_strain[2],
            self.c33 * d_shear[0],
            self.c33 * d_shear[1]])
