"""The host side of the model: scene + mesh -> numpy arrays, before any Taichi field exists
(named apart from the kernel stages of stages/).  assembly.py builds the Model (element
geometry, CPDI2 weights, masses, supports, loads, the grid); parts.py the parts and their
section and material tables; materials.py a material's table row; deck.py an LS-DYNA deck's
materials and sections as scene ones; bodies.py rigid bodies, point masses and walls;
tools.py the rigid tools' tables."""
