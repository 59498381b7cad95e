"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material model is a small class with a ``ti.func`` ``update(row, stress, plastic_strain,
strain_increment, shear_increment)`` that reads its parameters from ``row``, the point's
material's row of the material table (state.sections.material, columns in materials.py).
:class:`ConstitutiveUpdate` dispatches each point to its material's model with a
``ti.static`` loop over the models the scene uses (Features.materials), so only those are
compiled [choice, issue 17, as Genesis's MPM solver dispatches its materials]; parameter
values are run-time data (a changed E or yield stress loads the kernels from the cache).
"""

import taichi as ti

from ..materials import COL


@ti.data_oriented
class PlaneStressElastic:
    """Linear elastic, plane stress in plane, elastic transverse shear (tau += G dgamma;
    the shear factor is applied on the resultants, method.md 3.4-3.5)."""

    kind = "elastic"
    plastic = False

    @ti.func
    def elastic(self, row, stress, d_strain, d_shear):
        c11, c12, c33 = row[COL["c11"]], row[COL["c12"]], row[COL["c33"]]
        return stress + ti.Vector([
            c11 * d_strain[0] + c12 * d_strain[1],
            c12 * d_strain[0] + c11 * d_strain[1],
            c33 * d_strain[2],
            c33 * d_shear[0],
            c33 * d_shear[1]])

    @ti.func
    def update(self, row, stress, plastic_strain, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, plastic work per unit volume,
        whether the update converged)."""
        return self.elastic(row, stress, d_strain, d_shear), plastic_strain, 0.0, True


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
    kind = "j2"
    plastic = True
    max_iterations = 60

    @ti.func
    def flow_stress(self, row, ebar):
        return row[COL["yield_stress"]] + row[COL["hardening"]] * ebar

    @ti.func
    def consistency(self, row, a1, b, ebar_n, dlam):
        """F(dlambda), F'(dlambda) and ebar(dlambda) (method.md 3.4)."""
        lambda1, lambda2 = row[COL["lambda1"]], row[COL["lambda2"]]
        u1 = 1.0 / (1.0 + lambda1 * dlam)
        u2 = 1.0 / (1.0 + lambda2 * dlam)
        xi = a1 * u1 * u1 / 6.0 + b * u2 * u2
        dxi = -lambda1 * a1 * u1 ** 3 / 3.0 - 2.0 * lambda2 * b * u2 ** 3
        rate = ti.sqrt(2.0 * xi / 3.0)
        ebar = ebar_n + dlam * rate
        sy = self.flow_stress(row, ebar)
        f = 0.5 * xi - sy * sy / 3.0
        df = 0.5 * dxi - 2.0 / 3.0 * sy * row[COL["hardening"]] * (rate + dlam * dxi / (3.0 * rate))
        return f, df, ebar

    @ti.func
    def update(self, row, stress, plastic_strain, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, plastic work sigma_y(ebar_mid) d ebar,
        converged): a return that does not meet |F| < 1e-12 sigma_y^2 within max_iterations is
        reported (the shell stage stops the run naming the element), never accepted silently."""
        new = self.elastic(row, stress, d_strain, d_shear)
        ebar = plastic_strain
        work = 0.0
        converged = True
        s11, s22, s12 = new[0], new[1], new[2]
        q_trial = ti.sqrt(s11 * s11 - s11 * s22 + s22 * s22 + 3.0 * s12 * s12)
        sy_n = self.flow_stress(row, plastic_strain)
        if q_trial > sy_n:
            s_sum, s_diff = s11 + s22, s11 - s22
            a1 = s_sum * s_sum
            b = 0.5 * s_diff * s_diff + 2.0 * s12 * s12
            # F(0) = (q_trial^2 - sy_n^2)/3 > 0, and F <= 0 where xi(dlambda) <= xi(0)/(1 + lambda_min
            # dlambda)^2 reaches 2 sy_n^2/3: the root lies in [lo, hi].  Newton from 0; a Newton
            # iterate outside the bracket is replaced by bisection.
            lo, hi, dlam, root = 0.0, (q_trial / sy_n - 1.0) / row[COL["lambda_min"]], 0.0, 0.0
            converged = False
            for _iteration in range(self.max_iterations):
                f, df, ebar = self.consistency(row, a1, b, plastic_strain, dlam)
                root = dlam                      # the dlambda that ebar belongs to
                if ti.abs(f) < 1e-12 * self.flow_stress(row, ebar) ** 2:
                    converged = True
                    break
                if f > 0.0:
                    lo = dlam
                else:
                    hi = dlam
                dlam -= f / df
                if dlam <= lo or dlam >= hi:
                    dlam = 0.5 * (lo + hi)
            u1 = 1.0 / (1.0 + row[COL["lambda1"]] * root)
            u2 = 1.0 / (1.0 + row[COL["lambda2"]] * root)
            new[0] = 0.5 * (s_sum * u1 + s_diff * u2)
            new[1] = 0.5 * (s_sum * u1 - s_diff * u2)
            new[2] = s12 * u2
            work = self.flow_stress(row, 0.5 * (plastic_strain + ebar)) * (ebar - plastic_strain)
        return new, ebar, work, converged


MODELS = {cls.kind: cls for cls in (PlaneStressElastic, PlaneStressJ2)}    # materials.KINDS


@ti.data_oriented
class ConstitutiveUpdate:
    """The point update of the scene's materials: ``update(material, ...)`` runs the model of
    material index `material` (its kind is state.sections.material_kind, an index into
    Features.materials); only the models the scene uses are compiled."""

    def __init__(self, state, kinds: tuple[str, ...]):
        self.s = state
        self.models = tuple(MODELS[k]() for k in kinds)
        self.plastic = any(m.plastic for m in self.models)

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
    def update(self, kind, row, stress, plastic_strain, d_strain, d_shear):
        """The update of the model `kind` (index into Features.materials) with parameters `row`."""
        new, ebar, work, converged = stress, plastic_strain, 0.0, True
        if ti.static(len(self.models) == 1):
            new, ebar, work, converged = self.models[0].update(row, stress, plastic_strain, d_strain, d_shear)
        else:
            for i, model in ti.static(enumerate(self.models)):
                if kind == i:
                    new, ebar, work, converged = model.update(row, stress, plastic_strain, d_strain, d_shear)
        return new, ebar, work, converged
