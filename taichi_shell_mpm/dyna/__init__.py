"""LS-DYNA keyword decks (``.k``, ``.key``, ``.dyn``, ``.kw``).

* reader.py: the cards (fixed and free format, includes), the mesh, parts, sections,
  materials and curves (:func:`read_deck`), every other keyword kept for the scene reader;
* parameters.py: ``*PARAMETER`` / ``*PARAMETER_EXPRESSION`` and ``&name`` references;
* scene.py: a deck as a scene (:func:`deck_document`): its supports, motions, loads,
  initial velocities, walls, rigid parts, contacts, controls and outputs as the scene tables
  they mean, checked by the scene's own reader; what it does not read listed with line numbers.
"""
from .reader import DYNA_SUFFIXES, Block, Deck, DeckMaterial, DeckPart, DeckSection, Line, read_deck

__all__ = ["Block", "DYNA_SUFFIXES", "Deck", "DeckMaterial", "DeckPart", "DeckSection", "Line", "read_deck"]
