"""Scatter-add that is atomic only when it has to be.

In the batched launch (one serial loop of many steps, see
:mod:`taichi_shell_mpm.solvers.stepper`) nothing runs concurrently, and Taichi's f64
atomics (a compare-and-swap loop on x86) were measured to cost more than half of the
step: hemisphere quarter 16x16 in mpm mode, 223 us/step with atomics.  The switch is
compile-time.
"""
import taichi as ti


@ti.data_oriented
class Accumulator:
    def __init__(self, serial: bool):
        self.serial = serial

    @ti.func
    def add(self, field: ti.template(), index, value):
        if ti.static(self.serial):
            field[index] = field[index] + value
        else:
            field[index] += value

    @ti.func
    def total(self, field: ti.template(), value):
        """Add to a 0-d field (an energy or norm accumulated over nodes/elements)."""
        if ti.static(self.serial):
            field[None] = field[None] + value
        else:
            field[None] += value

    @ti.func
    def minimum(self, field: ti.template(), value):
        """field[None] = min(field[None], value)."""
        if ti.static(self.serial):
            field[None] = ti.min(field[None], value)
        else:
            ti.atomic_min(field[None], value)

    @ti.func
    def maximum(self, field: ti.template(), value):
        if ti.static(self.serial):
            field[None] = ti.max(field[None], value)
        else:
            ti.atomic_max(field[None], value)
