"""Errors Menagerie raises at its borders.

Every error a user can cause names where the fault is: the file, the line, the body or
channel, the field. Kernels never see bad input; the loaders and builders catch it first.
"""

from __future__ import annotations


class MenagerieError(Exception):
    """Base class of every error Menagerie raises on purpose."""


class DataError(MenagerieError, ValueError):
    """Bad input data, located as precisely as the loader can.

    Attributes are kept so tools can point at the fault: ``path`` (file or None),
    ``line`` (1-based or None), ``subject`` (a body or channel name, or None) and
    ``field`` (the field name, or None).
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | None = None,
        line: int | None = None,
        subject: str | None = None,
        field: str | None = None,
        kind: str = "body",
    ) -> None:
        self.path = path
        self.line = line
        self.subject = subject
        self.field = field
        self.kind = kind
        self.reason = message
        where = []
        if path is not None:
            where.append(f"{path}:{line}" if line is not None else str(path))
        elif line is not None:
            where.append(f"line {line}")
        if subject is not None:
            where.append(f"{kind} '{subject}'")
        if field is not None:
            where.append(f"field '{field}'")
        prefix = ", ".join(where)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class CreatureError(DataError):
    """A creature file or definition that cannot be built."""


class BvhError(DataError):
    """A BVH file that cannot be read."""
