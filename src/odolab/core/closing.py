"""One way for an object that holds a resource to be a context manager.

``with Notebook(path) as nb:`` gives the object itself and calls its ``close`` on the way out,
whatever happens in the block. A class that holds a connection, a server or a file derives from
:class:`Closing` and writes only its ``close``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Self

__all__ = ["Closing"]


class Closing(ABC):
    """A context manager that gives the object itself and closes it when the block ends."""

    @abstractmethod
    def close(self) -> None:
        """Let go of what the object holds."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
