"""von Mises (J2) plasticity in plane stress: ``[material].model = "j2"``, with the hardening
and rate laws of laws/hardening/ and laws/rate/ and the failure criteria of laws/failure/.
Its return map is the base of the plug-in yield functions (hill48.py).  Elastic part:
elastic.py's."""
from __future__ import annotations

import math

from . import elastic
from .hardening import LAWS as HARDENING_LAWS
from .rate import LAWS as RATE_LAWS

NAME = "j2"
DOC = ("`j2`: von Mises plasticity in plane stress with isotropic hardening, flow stress σ_f = σ_y(ε̄ᵖ) R(ε̇) of the "
       "hardening and rate laws below (consistent plane-stress return map, method.md 3.4; a return that does not "
       "converge stops the run naming the element)")
KEYS: dict = {}
TABLE = None
PLASTIC = True
ORIENTED = False
BLOCK: tuple[str, ...] = ()
stiffness, transverse_shear = elastic.stiffness, elastic.transverse_shear          # its elastic part
wave_speed, dilatational_speed = elastic.wave_speed, elastic.dilatational_speed


def rate_filter_time(spec) -> float:
    """The time constant tau of the material's rate filter (0: unfiltered): rate_filter_time,
    or 1 / (2 pi f_c) of rate_cutoff_frequency."""
    if spec.rate_cutoff_frequency > 0.0:
        return 1.0 / (2.0 * math.pi * spec.rate_cutoff_frequency)
    return spec.rate_filter_time


def values(spec, context) -> dict[str, float]:
    """Its columns of the material row: elastic.py's, the eigenvalues of the return
    (lambda1 = E / (3 (1 - nu)), lambda2 = 2G, the smaller), the flow stress's yield stress,
    H, law indices into the scene's compiled laws (context.hardening, context.rates; -1: no
    rate law) and their parameter blocks, the rate measure and filter."""
    out = elastic.values(spec, context)
    E, nu, G = spec.E, spec.nu, elastic.shear_modulus(spec)
    lam1, lam2 = E / (3.0 * (1.0 - nu)), 2.0 * G
    out.update(yield_stress=spec.yield_stress, hardening=spec.hardening, lambda1=lam1, lambda2=lam2,
               lambda_min=min(lam1, lam2), hardening_law=context.hardening.index(spec.hardening_law),
               rate_law=context.rates.index(spec.rate_law) if spec.rate_law in context.rates else -1,
               rate_plastic=float(spec.rate_measure == "plastic"), rate_filter_time=rate_filter_time(spec))
    out.update({f"hardening_{i}": x for i, x in
                enumerate(HARDENING_LAWS[spec.hardening_law].block(spec, context.curve_start))})
    if spec.rate_law in RATE_LAWS:
        out.update({f"rate_{i}": x for i, x in enumerate(RATE_LAWS[spec.rate_law].block(spec))})
    return out


def kernel(context):
    """The point update on elastic's (context.models["elastic"]) with the scene's laws'
    kernels (context.hardening_kernels, context.rate_kernels)."""
    import taichi as ti
    COL = context.col
    HARDENING, RATE = context.hardening_kernels, context.rate_kernels
    PlaneStressElastic = context.models["elastic"]

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

    return PlaneStressJ2
