"""Solvers: the explicit step (:mod:`.stepper`) and the drivers for static (load control
with dynamic relaxation) and dynamic (explicit to an end time) runs."""
