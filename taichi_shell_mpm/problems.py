"""The error every reader of user input raises: scene files, meshes, LS-DYNA decks.

Its own module so that the readers below the scene (dyna/, the deck reader the scene uses)
raise it without importing the scene package."""
from __future__ import annotations


class SceneError(Exception):
    """A user mistake in a scene file or a mesh (one line per problem)."""

    def __init__(self, messages: list[str] | str, mesh=None):
        self.messages = [messages] if isinstance(messages, str) else list(messages)
        self.mesh = mesh
        """The scene's valid [mesh] table when other tables had problems (so that the mesh can
        be checked as well and every problem reported at once), else None."""
        super().__init__("\n".join(self.messages))
