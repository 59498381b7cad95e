"""A harmonic oscillator (omega = 1) under the central difference with the averaged kick
h = (dt^(n-1/2) + dt^(n+1/2)) / 2 (selective mass scaling's, stages/timestep.impulse_time),
its step cut from 0.78 to 0.546 (-30 %, the feature matrix's sheet with a sphere tool under
selective scaling: docs/mass_scaling.md, "A step that changes").

Prints, for an abrupt cut at 8 phases and for ramps over 1-1000 steps: the squared amplitude
after / before (the motion's energy) and the balance quantity E^n = 1/2 v^2 + 1/2 x^n x^(n+1)
after / before, without and with the step-change term (dt+ - dt-) h / 4 f_int . a that
stages/selective_mass.SelectiveMass.step_change books (with it E^n + booked stays constant to
round-off).  Run: python benchmarks/variable_step_oscillator.py
"""
import numpy as np


def run(dts):
    x, v, last = 1.0, 0.5 * dts[0], dts[0]        # v^(-1/2) = +dt/2 x: x = 1 is a turning point
    xs, shadow, booked = [], [], []
    total = 0.0
    for dt in dts:
        h = 0.5 * (last + dt)
        f = -x                                   # f_int = K x = x, a = -x
        total += 0.25 * (dt - last) * h * (x * f)
        v += h * f
        x_new = x + dt * v
        shadow.append(0.5 * v * v + 0.5 * x * x_new)
        booked.append(total)
        x, last = x_new, dt
        xs.append(x)
    return np.array(xs), np.array(shadow), np.array(booked)


def report(label, dts, cut):
    xs, e, booked = run(dts)
    before, after = np.abs(xs[cut - 1000:cut]).max(), np.abs(xs[-1000:]).max()
    i = cut - 500
    print(f"{label}: amplitude^2 {(after / before) ** 2 - 1:+.4f}; E^n {e[-1] / e[i] - 1:+.4f}; "
          f"E^n - booked {(e[-1] - booked[-1]) / (e[i] - booked[i]) - 1:+.1e}")


if __name__ == "__main__":
    d0, d1 = 0.78, 0.546
    for phase in range(8):
        report(f"cut at phase step {phase}", [d0] * (2000 + phase) + [d1] * 4000, 2000)
    for n in (1, 10, 100, 1000):
        report(f"ramp over {n} steps", [d0] * 2000 + list(np.linspace(d0, d1, n)) + [d1] * 4000, 2000)
