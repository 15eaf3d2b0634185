"""Tag id sets written as text: ``"0-24"``, ``"0,3,7-9"``, ``""`` (none).

ROS parameter files cannot hold an empty list, and id sets are naturally ranges, so the
detector takes them as strings in this small syntax.
"""

from __future__ import annotations


def parse_id_set(text: str, name: str = "ids") -> frozenset[int]:
    """Parse comma-separated ids and inclusive ranges ``a-b``.

    Raises:
        ValueError: a malformed item, a negative id or a reversed range (names ``name``).
    """
    ids: set[int] = set()
    for raw in text.split(","):
        item = raw.strip()
        if not item:
            continue
        lo_text, sep, hi_text = item.partition("-")
        try:
            lo = int(lo_text)
            hi = int(hi_text) if sep else lo
        except ValueError:
            raise ValueError(f"parameter '{name}': bad item '{item}' in '{text}' "
                             "(expected ids and ranges like '0-24,30')") from None
        if lo < 0 or hi < lo:
            raise ValueError(f"parameter '{name}': bad range '{item}' (need 0 <= a <= b)")
        ids.update(range(lo, hi + 1))
    return frozenset(ids)


def format_id_set(ids) -> str:
    """The shortest text ``parse_id_set`` reads back as ``ids``."""
    items, run = [], []
    for i in sorted(set(ids)):
        if run and i == run[-1] + 1:
            run.append(i)
            continue
        if run:
            items.append(_run_text(run))
        run = [i]
    if run:
        items.append(_run_text(run))
    return ",".join(items)


def _run_text(run: list[int]) -> str:
    return str(run[0]) if len(run) == 1 else f"{run[0]}-{run[-1]}"
