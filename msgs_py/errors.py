"""The one error type of the message layer.

Every rejection names the offending field (a dotted path such as ``blocks[3].x``) and the
value found there, so a user can fix a scene file or a payload without reading code.
"""

from __future__ import annotations

from typing import Any


class MessageError(ValueError):
    """A payload or file that does not satisfy the densepack schema.

    Attributes:
        field: dotted path of the offending field, e.g. ``goal.poses[2].id``.
        value: the value found there (or a summary of it).
        reason: what is wrong, in words.
    """

    def __init__(self, field: str, value: Any, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"{field}: {reason} (got {_short_repr(value)})")

    def __reduce__(self) -> tuple[type, tuple[str, Any, str]]:
        """Pickled with its fields (a plan's process sends it back to the planner node)."""
        return type(self), (self.field, self.value, self.reason)


def _short_repr(value: Any, limit: int = 120) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
