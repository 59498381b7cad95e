"""Constitutive updates at one through-thickness point, in the corotational frame (method.md 3.4).

A material model is a small class with a ``ti.func`` ``update(row, axes, stress,
plastic_strain, strain_rate, strain_increment, shear_increment, dt)`` that reads its
parameters from ``row``, the point's material's row of the material table
(state.sections.material, columns in model/materials.py); ``axes`` = (cos, sin) of the angle from
the element's e1 to the point's material 1-axis, which only the orthotropic model reads
(docs/laminates.md).  :class:`ConstitutiveUpdate` dispatches each point to its material's
model with a ``ti.static`` loop over the models the scene uses (Features.materials), so only
those are compiled [choice, issue 17, as Genesis's MPM solver dispatches its materials]; parameter
values are run-time data (a changed E or yield stress loads the kernels from the cache).
The J2 model's flow stress sigma_y(ebar) R(rate) dispatches the same way over the hardening
and rate laws the scene uses (Features.hardening, Features.rate_laws; one file each in
laws/hardening/ and laws/rate/): the laws' parameters, the tabulated curves included, are
run-time data too.
"""

import taichi as ti

from ..laws import MODELS as PLUG_INS
from ..laws.hardening import LAWS as HARDENING_LAWS
from ..laws.rate import LAWS as RATE_LAWS
from ..model.materials import BLOCK_OFFSET, COL, ORIENTED

# ---------------------------------------------------------------- flow-stress laws (laws/hardening/, laws/rate/)
_SHARED = {name: COL[name] for name in ("yield_stress", "hardening")}
HARDENING = {name: law.kernel(COL["hardening_0"], _SHARED) for name, law in HARDENING_LAWS.items()}
"""sigma_y(ebar) of each hardening law (materials.HARDENING_LAWS)."""
RATE = {name: law.kernel(COL["rate_0"]) for name, law in RATE_LAWS.items()}
"""R(rate) of each rate law (materials.RATE_LAWS)."""


@ti.func
def effective_strain_increment(d_strain):
    """sqrt(2/3 de:de) of the in-plane increment (dexx, deyy, dgxy) completed by the isochoric
    dezz = -(dexx + deyy): (2/sqrt 3) sqrt(dexx^2 + dexx deyy + deyy^2 + dgxy^2 / 4), the
    equivalent plastic strain increment of any plastic (incompressible) flow; uniaxial
    elastic stretching with Poisson's ratio nu gives (2/sqrt 3) sqrt(1 - nu + nu^2) dexx."""
    return 2.0 / ti.sqrt(3.0) * ti.sqrt(d_strain[0] * d_strain[0] + d_strain[0] * d_strain[1]
                                        + d_strain[1] * d_strain[1] + 0.25 * d_strain[2] * d_strain[2])


# ---------------------------------------------------------------- material models
@ti.data_oriented
class PlaneStressElastic:
    """Linear elastic, plane stress in plane, elastic transverse shear (tau += G dgamma;
    the shear factor is applied on the resultants, method.md 3.4-3.5)."""

    kind = "elastic"
    plastic = False

    def __init__(self, state=None):
        pass

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
    def update(self, row, axes, stress, plastic_strain, strain_rate, d_strain, d_shear, dt):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz).
        Returns (new stress, new equivalent plastic strain, new filtered strain rate, plastic
        work per unit volume, whether the update converged).  Isotropic: `axes` is not read."""
        return self.elastic(row, stress, d_strain, d_shear), plastic_strain, strain_rate, 0.0, True


@ti.data_oriented
class PlaneStressJ2(PlaneStressElastic):
    """von Mises plasticity in plane stress with isotropic hardening: flow stress
    sigma_y(ebar) R(rate), sigma_y of the material's hardening law and R of its rate law
    (1 without one); transverse shear stays elastic.

    Elastic predictor, then the plane-stress return map of Simo & Taylor (1986) (de Souza
    Neto et al. 2008, 9.4) exactly as method.md 3.4.  The backward-Euler return
    sigma = sigma_trial - dlambda C P sigma, P = [[2,-1,0],[-1,2,0],[0,0,6]]/3, is diagonal in
    the common eigenbasis of C and P (eigenvalues of C P: lambda1 on (1,1,0), lambda2 on
    (1,-1,0) and (0,0,1)), so consistency is one scalar equation
    F(dlambda) = xi/2 - sigma_f^2/3 = 0, with xi = sigma.P.sigma = 2 q^2/3 and sigma_f the flow
    stress at ebar(dlambda), solved by Newton with the law's slope, safeguarded by bisection.

    The rate is linear in the plastic strain increment of the step: rate = base + weight
    (ebar - ebar_n), with the filter factor alpha = 1 - exp(-dt / tau) (1 unfiltered) and the
    filtered rate r_n of the point's last step:
    total strain rate (LS-DYNA VP = 0): base = alpha r_t + (1 - alpha) r_n with the effective
    total strain rate r_t of the step's increment (effective_strain_increment / dt), weight 0,
    so R is a constant of the return;
    plastic strain rate (VP = 1): base = (1 - alpha) r_n, weight = alpha / dt, so the flow
    stress rises with the step's plastic strain increment and F' carries
    sigma_y R'(rate) weight d ebar / d dlambda (a viscoplastic overstress: plastic flow starts
    where q_trial exceeds sigma_y(ebar_n) R(base)).
    Either way the flow stress never falls as dlambda grows, so F(hi) <= 0 at the bracket's
    upper end below and the root is unique.  The new filtered rate is base + weight d ebar.
    """
    kind = "j2"
    plastic = True
    max_iterations = 60

    def __init__(self, state=None, hardening=None, rates=None):
        fx = state.features if state is not None else None
        hardening = hardening or (fx.hardening if fx is not None and fx.hardening else ("linear",))
        rates = rates if rates is not None else (fx.rate_laws if fx is not None else ())
        self.laws = tuple(HARDENING[law](state) for law in hardening)
        self.rates = tuple(RATE[law]() for law in rates)

    @ti.func
    def hardening(self, row, ebar):
        """sigma_y(ebar) and its slope, of the material's law."""
        sy, slope = 0.0, 0.0
        if ti.static(len(self.laws) == 1):
            sy, slope = self.laws[0].flow_stress(row, ebar)
        else:
            law = ti.cast(row[COL["hardening_law"]], ti.i32)
            for i, model in ti.static(enumerate(self.laws)):
                if law == i:
                    sy, slope = model.flow_stress(row, ebar)
        return sy, slope

    @ti.func
    def regula_falsi(self, row):
        """Whether the return's step outside its bracket is the Illinois one: for every law but
        the rate-free linear one, which keeps the bisection of issue 17 (its runs stay the same
        bit for bit; the linear law's Newton leaves the bracket only next to the root, where
        either step does)."""
        out = False
        if ti.static(self.rates):
            out = row[COL["rate_law"]] >= 0.0
        law = ti.cast(row[COL["hardening_law"]], ti.i32)
        for i, model in ti.static(enumerate(self.laws)):
            if ti.static(model.law != "linear"):
                if law == i:
                    out = True
        return out

    @ti.func
    def rate_factor(self, row, rate):
        """R(rate) and dR / d rate of the material's rate law (1, 0 without one)."""
        R, dR = 1.0, 0.0
        law = ti.cast(row[COL["rate_law"]], ti.i32)
        for i, model in ti.static(enumerate(self.rates)):
            if law == i:
                R, dR = model.factor(row, rate)
        return R, dR

    @ti.func
    def flow_stress(self, row, ebar, rate, weight, fixed):
        """sigma_f = sigma_y(ebar) R(rate) and d sigma_f / d ebar along the return (rate =
        base + weight (ebar - ebar_n)).  With weight 0 (the total strain rate) R is a constant
        of the return: `fixed` = (R, dR) of the base rate, computed once per point."""
        sy, slope = self.hardening(row, ebar)
        if ti.static(self.rates):
            R, dR = fixed[0], fixed[1]
            if weight > 0.0:
                R, dR = self.rate_factor(row, rate)
            sy, slope = sy * R, slope * R + sy * dR * weight
        return sy, slope

    @ti.func
    def trial(self, row, axes, trial):
        """The von Mises stress q of the in-plane trial stress and the terms of its return:
        a1 = (s11 + s22)^2 and b = (s11 - s22)^2 / 2 + 2 s12^2, its projections on the
        eigenvectors of C P, then s11 + s22, s11 - s22, s12 (method.md 3.4).  Isotropic:
        `axes` is not read."""
        s11, s22, s12 = trial[0], trial[1], trial[2]
        q = ti.sqrt(s11 * s11 - s11 * s22 + s22 * s22 + 3.0 * s12 * s12)
        s_sum, s_diff = s11 + s22, s11 - s22
        return q, ti.Vector([s_sum * s_sum, 0.5 * s_diff * s_diff + 2.0 * s12 * s12, s_sum, s_diff, s12])

    @ti.func
    def smallest_eigenvalue(self, row):
        """The smallest eigenvalue of C P (the return's bracket)."""
        return row[COL["lambda_min"]]

    @ti.func
    def xi(self, row, terms, dlam):
        """xi(dlambda) = sigma.P.sigma of the returned stress and its derivative:
        a1 u1^2 / 6 + b u2^2 with u_i = 1 / (1 + lambda_i dlambda)."""
        lambda1, lambda2 = row[COL["lambda1"]], row[COL["lambda2"]]
        u1 = 1.0 / (1.0 + lambda1 * dlam)
        u2 = 1.0 / (1.0 + lambda2 * dlam)
        xi = terms[0] * u1 * u1 / 6.0 + terms[1] * u2 * u2
        dxi = -lambda1 * terms[0] * u1 ** 3 / 3.0 - 2.0 * lambda2 * terms[1] * u2 ** 3
        return xi, dxi

    @ti.func
    def returned(self, row, axes, stress, terms, dlam):
        """`stress` with its in-plane part returned by dlambda: (I + dlambda C P)^-1 sigma_trial."""
        u1 = 1.0 / (1.0 + row[COL["lambda1"]] * dlam)
        u2 = 1.0 / (1.0 + row[COL["lambda2"]] * dlam)
        s_sum, s_diff = terms[2], terms[3]
        out = stress
        out[0] = 0.5 * (s_sum * u1 + s_diff * u2)
        out[1] = 0.5 * (s_sum * u1 - s_diff * u2)
        out[2] = terms[4] * u2
        return out

    @ti.func
    def consistency(self, row, terms, ebar_n, dlam, base, weight, fixed):
        """F(dlambda), F'(dlambda), ebar(dlambda), its increment and the flow stress there
        (method.md 3.4).  The rate takes the increment itself, not ebar - ebar_n: that
        difference keeps only the digits of the increment that ebar_n leaves, and the steps
        of R it then makes were larger than the tolerance on F (a tube point with ebar_n
        ~0.1 and d ebar ~1e-7 never converged)."""
        xi, dxi = self.xi(row, terms, dlam)
        flow_rate = ti.sqrt(2.0 * xi / 3.0)          # d ebar / d dlambda at fixed xi
        ebar = ebar_n + dlam * flow_rate
        increment = 0.0
        if ti.static(self.rates):                    # (without, the rate-free arithmetic of issue 17)
            increment = dlam * flow_rate
        sy, slope = self.flow_stress(row, ebar, base + weight * increment, weight, fixed)
        f = 0.5 * xi - sy * sy / 3.0
        df = 0.5 * dxi - 2.0 / 3.0 * sy * slope * (flow_rate + dlam * dxi / (3.0 * flow_rate))
        return f, df, ebar, increment, sy

    @ti.func
    def update(self, row, axes, stress, plastic_strain, strain_rate, d_strain, d_shear, dt):
        """stress = (sxx, syy, sxy, txz, tyz); d_strain = (dexx, deyy, dgxy); d_shear = (dgxz, dgyz);
        strain_rate: the point's filtered rate of the last step (0 unfiltered).  Returns (new
        stress, new equivalent plastic strain, new filtered rate, plastic work
        sigma_f(ebar_mid) d ebar, converged): a return that does not meet |F| < 1e-12 sigma_f^2
        within max_iterations is reported (the shell stage stops the run naming the element),
        never accepted silently."""
        new = self.elastic(row, stress, d_strain, d_shear)
        ebar = plastic_strain
        work = 0.0
        converged = True
        base, weight, increment = 0.0, 0.0, 0.0      # the rate: base + weight d ebar
        if ti.static(self.rates):
            alpha = 1.0
            if row[COL["rate_filter_time"]] > 0.0:
                alpha = 1.0 - ti.exp(-dt / row[COL["rate_filter_time"]])
            if row[COL["rate_plastic"]] > 0.0:
                base, weight = (1.0 - alpha) * strain_rate, alpha / dt
            else:
                base = alpha * (effective_strain_increment(d_strain) / dt) + (1.0 - alpha) * strain_rate
        q_trial, terms = self.trial(row, axes, new)
        # R >= 1: a trial stress below the rate-free sigma_y(ebar_n) is elastic at any rate, and
        # R is not evaluated (most points, most steps) [choice, measured: docs/performance.md]
        sy_n, _ = self.hardening(row, plastic_strain)
        fixed = ti.Vector([1.0, 0.0])
        if ti.static(self.rates):
            if q_trial > sy_n:
                R, dR = self.rate_factor(row, base)
                fixed = ti.Vector([R, dR])
                sy_n, _ = self.flow_stress(row, plastic_strain, base, weight, fixed)
        if q_trial > sy_n:
            # F(0) = (q_trial^2 - sy_n^2)/3 > 0, and F <= 0 where xi(dlambda) <= xi(0)/(1 + lambda_min
            # dlambda)^2 reaches 2 sy_n^2/3: the root lies in [lo, hi].  Newton from 0; a Newton
            # iterate outside the bracket is replaced by bisection, or (regula_falsi) by the Illinois
            # regula falsi point of the bracket once F is known at both ends (F halved at the end
            # that stayed twice).  [choice, measured] Bisection alone needed up to 60 iterations
            # where a trial just above yield puts the root of a power-law rate within 1e-20 of 0
            # (Cowper-Symonds p = 5 on the plastic rate: Newton from the right lands below 0 every
            # time); with the Illinois step at most 17 (a numpy copy of this loop, 20 000 random
            # trials 1e-10 to 10 above yield).
            lo, hi, dlam, root = 0.0, (q_trial / sy_n - 1.0) / self.smallest_eigenvalue(row), 0.0, 0.0
            f_lo, f_hi, side = 0.0, 0.0, 0           # F at the ends; the end moved last (1: lo, -1: hi)
            converged = False
            for _iteration in range(self.max_iterations):
                f, df, ebar_k, increment_k, sy = self.consistency(row, terms, plastic_strain, dlam, base, weight,
                                                                  fixed)
                ebar, increment = ebar_k, increment_k
                root = dlam                      # the dlambda that ebar belongs to
                if ti.abs(f) < 1e-12 * sy ** 2:
                    converged = True
                    break
                if f > 0.0:
                    lo, f_lo = dlam, f
                    if side == 1:
                        f_hi *= 0.5
                    side = 1
                else:
                    hi, f_hi = dlam, f
                    if side == -1:
                        f_lo *= 0.5
                    side = -1
                dlam -= f / df
                if dlam <= lo or dlam >= hi:
                    dlam = 0.5 * (lo + hi)
                    if f_hi < 0.0 and self.regula_falsi(row):
                        dlam = lo + (hi - lo) * f_lo / (f_lo - f_hi)
            new = self.returned(row, axes, new, terms, root)
            sy_mid, _ = self.flow_stress(row, 0.5 * (plastic_strain + ebar), base + weight * increment, weight, fixed)
            work = sy_mid * (ebar - plastic_strain)
        return new, ebar, base + weight * increment, work, converged


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

    def __init__(self, state=None):
        pass

    @ti.func
    def update(self, row, axes, stress, plastic_strain, strain_rate, d_strain, d_shear, dt):
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
            s * t13 + c * t23]), plastic_strain, strain_rate, 0.0, True


MODELS = {cls.kind: cls for cls in (PlaneStressElastic, PlaneStressJ2, PlaneStressOrthotropic,
                                     *(law.kernel(PlaneStressJ2, BLOCK_OFFSET) for law in PLUG_INS.values()))}
"""Every model, materials.KINDS: the built-in ones and the plug-ins of laws/ (on the J2 return)."""


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
