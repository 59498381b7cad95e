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
        Returns (new stress, new equivalent plastic strain, plastic work per unit volume,
        whether the update converged)."""
        new = stress + ti.Vector([
            self.c11 * d_strain[0] + self.c12 * d_strain[1],
            self.c12 * d_strain[0] + self.c11 * d_strain[1],
            self.c33 * d_strain[2],
            self.c33 * d_shear[0],
            self.c33 * d_shear[1]])
        return new, plastic_strain, 0.0, True


@ti.data_oriented
class PlaneStressJ2(PlaneStressElastic):
    """von Mises plasticity in plane stress with linear isotropic hardening
    sigma_y(ebar) = yield_stress + hardening * ebar; transverse shear stays elastic.

    Elastic predictor, then the plane-stress return map of Simo & Taylor (1986) (de Souza
    Neto et al. 2008, 9.4) exactly as method.md 3.4.  The backward-Euler return
    sigma = sigma_trial - dlambda C P sigma, P = [[2,-1,0],[-1,2,0],[0,0,6]]/3, is diagonal in
    the common eigenbasis of C and P (eigenvalues of C P: lambda1 on (1,1,0), lambda2 on
    (1,-1,0) and (0,0,1)), so consistency is one scalar equation
    F(dlambda) = xi/2 - sigma_y(ebar)^2/3 = 0, with xi = sigma.P.sigma = 2 q^2/3.
    """
    plastic = True
    max_iterations = 60

    def __init__(self, E: float, nu: float, yield_stress: float, hardening: float):
        super().__init__(E, nu)
        self.yield_stress = yield_stress
        self.hardening = hardening
        self.lambda1 = E / (3.0 * (1.0 - nu))
        self.lambda2 = 2.0 * self.c33
        self.lambda_min = min(self.lambda1, self.lambda2)

    @ti.func
    def flow_stress(self, ebar):
        return self.yield_stress + self.hardening * ebar

    @ti.func
    def consistency(self, a1, b, ebar_n, dlam):
        """F(dlambda), F'(dlambda) and ebar(dlambda) (method.md 3.4)."""
        u1 = 1.0 / (1.0 + self.lambda1 * dlam)
        u2 = 1.0 / (1.0 + self.lambda2 * dlam)
        xi = a1 * u1 * u1 / 6.0 + b * u2 * u2
        dxi = -self.lambda1 * a1 * u1 ** 3 / 3.0 - 2.0 * self.lambda2 * b * u2 ** 3
        rate = ti.sqrt(2.0 * xi / 3.0)
        ebar = ebar_n + dlam * rate
        sy = self.flow_stress(ebar)
        f = 0.5 * xi - sy * sy / 3.0
        df = 0.5 * dxi - 2.0 / 3.0 * sy * self.hardening * (rate + dlam * dxi / (3.0 * rate))
        return f, df, ebar

    @ti.func
    def update(self, stress, plastic_strain, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, plastic work sigma_y(ebar_mid) d ebar,
        converged): a return that does not meet |F| < 1e-12 sigma_y^2 within max_iterations is
        reported (the shell stage stops the run naming the element), never accepted silently."""
        new, _, _, _ = PlaneStressElastic.update(self, stress, plastic_strain, d_strain, d_shear)
        ebar = plastic_strain
        work = 0.0
        converged = True
        s11, s22, s12 = new[0], new[1], new[2]
        q_trial = ti.sqrt(s11 * s11 - s11 * s22 + s22 * s22 + 3.0 * s12 * s12)
        sy_n = self.flow_stress(plastic_strain)
        if q_trial > sy_n:
            s_sum, s_diff = s11 + s22, s11 - s22
            a1 = s_sum * s_sum
            b = 0.5 * s_diff * s_diff + 2.0 * s12 * s12
            # F(0) = (q_trial^2 - sy_n^2)/3 > 0, and F <= 0 where xi(dlambda) <= xi(0)/(1 + lambda_min
            # dlambda)^2 reaches 2 sy_n^2/3: the root lies in [lo, hi].  Newton from 0; a Newton
            # iterate outside the bracket is replaced by bisection.
            lo, hi, dlam, root = 0.0, (q_trial / sy_n - 1.0) / self.lambda_min, 0.0, 0.0
            converged = False
            for _iteration in range(self.max_iterations):
                f, df, ebar = self.consistency(a1, b, plastic_strain, dlam)
                root = dlam                      # the dlambda that ebar belongs to
                if ti.abs(f) < 1e-12 * self.flow_stress(ebar) ** 2:
                    converged = True
                    break
                if f > 0.0:
                    lo = dlam
                else:
                    hi = dlam
                dlam -= f / df
                if dlam <= lo or dlam >= hi:
                    dlam = 0.5 * (lo + hi)
            u1 = 1.0 / (1.0 + self.lambda1 * root)
            u2 = 1.0 / (1.0 + self.lambda2 * root)
            new[0] = 0.5 * (s_sum * u1 + s_diff * u2)
            new[1] = 0.5 * (s_sum * u1 - s_diff * u2)
            new[2] = s12 * u2
            work = self.flow_stress(0.5 * (plastic_strain + ebar)) * (ebar - plastic_strain)
        return new, ebar, work, converged
