"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material model is a small class with a ``ti.func`` ``update(row, axes, stress,
plastic_strain, strain_increment, shear_increment)`` that reads its parameters from ``row``,
the point's material's row of the material table (state.sections.material, columns in
materials.py); ``axes`` = (cos, sin) of the angle from the element's e1 to the point's
material 1-axis, which only the orthotropic model reads (docs/laminates.md).
:class:`ConstitutiveUpdate` dispatches each point to its material's model with a
``ti.static`` loop over the models the scene uses (Features.materials), so only those are
compiled [choice, issue 17, as Genesis's MPM solver dispatches its materials]; parameter
values are run-time data (a changed E or yield stress loads the kernels from the cache).
"""

import taichi as ti

from ..materials import COL, ORIENTED


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
    def update(self, row, axes, stress, plastic_strain, d_strain, d_shear):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, plastic work per unit volume,
        whether the update converged).  Isotropic: `axes` is not read."""
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
    def update(self, row, axes, stress, plastic_strain, d_strain, d_shear):
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


@ti.data_oriented
class PlaneStressOrthotropic:
    """Linear elastic orthotropic ply in plane stress with elastic transverse shear
    (docs/laminates.md).  The strain increment is turned into the material axes (1 at the
    angle theta from e1, counter-clockwise about e3; c = cos, s = sin), met by the ply's own
    stiffness, and the stress increment turned back:
    de11 = c^2 dexx + s^2 deyy + c s dgxy, de22 = s^2 dexx + c^2 deyy - c s dgxy,
    dg12 = 2 c s (deyy - dexx) + (c^2 - s^2) dgxy; ds = Q de (Q11, Q22, Q12, Q66 = G12);
    dsxx = c^2 ds11 + s^2 ds22 - 2 c s dt12, dsyy = s^2 ds11 + c^2 ds22 + 2 c s dt12,
    dsxy = c s (ds11 - ds22) + (c^2 - s^2) dt12: the increment of Q_bar = T^-1 Q T^-T.
    Transverse shear: dg13 = c dgxz + s dgyz, dg23 = -s dgxz + c dgyz, dt13 = G13 dg13,
    dt23 = G23 dg23, dtxz = c dt13 - s dt23, dtyz = s dt13 + c dt23."""

    kind = "orthotropic"
    plastic = False

    @ti.func
    def update(self, row, axes, stress, plastic_strain, d_strain, d_shear):
        """As PlaneStressElastic.update, in the material axes `axes` = (cos, sin)."""
        c, s = axes[0], axes[1]
        cc, ss, cs = c * c, s * s, c * s
        e11 = cc * d_strain[0] + ss * d_strain[1] + cs * d_strain[2]
        e22 = ss * d_strain[0] + cc * d_strain[1] - cs * d_strain[2]
        g12 = 2.0 * cs * (d_strain[1] - d_strain[0]) + (cc - ss) * d_strain[2]
        s11 = row[COL["c11"]] * e11 + row[COL["c12"]] * e22
        s22 = row[COL["c12"]] * e11 + row[COL["c22"]] * e22
        t12 = row[COL["c33"]] * g12
        t13 = row[COL["shear_13"]] * (c * d_shear[0] + s * d_shear[1])
        t23 = row[COL["shear_23"]] * (c * d_shear[1] - s * d_shear[0])
        return stress + ti.Vector([
            cc * s11 + ss * s22 - 2.0 * cs * t12,
            ss * s11 + cc * s22 + 2.0 * cs * t12,
            cs * (s11 - s22) + (cc - ss) * t12,
            c * t13 - s * t23,
            s * t13 + c * t23]), plastic_strain, 0.0, True


MODELS = {cls.kind: cls for cls in (PlaneStressElastic, PlaneStressJ2, PlaneStressOrthotropic)}   # materials.KINDS


@ti.data_oriented
class ConstitutiveUpdate:
    """The point update of the scene's materials: ``update(kind, row, axes, ...)`` runs the
    model `kind` (state.sections.material_kind of the point's material, an index into
    Features.materials); only the models the scene uses are compiled."""

    def __init__(self, state, kinds: tuple[str, ...]):
        self.s = state
        self.models = tuple(MODELS[k]() for k in kinds)
        self.plastic = any(m.plastic for m in self.models)
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
    def update(self, kind, row, axes, stress, plastic_strain, d_strain, d_shear):
        """The update of the model `kind` (index into Features.materials) with parameters `row`."""
        new, ebar, work, converged = stress, plastic_strain, 0.0, True
        if ti.static(len(self.models) == 1):
            new, ebar, work, converged = self.models[0].update(row, axes, stress, plastic_strain, d_strain, d_shear)
        else:
            for i, model in ti.static(enumerate(self.models)):
                if kind == i:
                    new, ebar, work, converged = model.update(row, axes, stress, plastic_strain, d_strain, d_shear)
        return new, ebar, work, converged
