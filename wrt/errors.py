"""Errors that wrt raises for bad input, so callers can tell them from bugs."""


class SceneError(ValueError):
    """A scene file or its content cannot be used.

    The message always names the file and, where one is involved, the prim path,
    e.g. ``scene.usda: /World/Mesh: faceVertexIndices[12] = 40 is out of range (20 points)``.
    """

    def __init__(self, message: str, *, path: str | None = None, prim: str | None = None):
        self.path = path  # file the problem was found in, if any
        self.prim = prim  # prim path the problem was found at, if any
        parts = [p for p in (path, prim) if p]
        super().__init__(": ".join(parts + [message]))
