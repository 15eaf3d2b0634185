"""Where densepack's data lives: ``config/`` and ``sim_assets/``.

A checkout (editable install) keeps them beside the Python packages; a colcon install puts
them in ``share/densepack``. ``DENSEPACK_SHARE`` overrides both.
"""

from __future__ import annotations

import os
from functools import cache
from pathlib import Path

from ament_index_python.packages import get_package_share_directory


@cache
def share_dir() -> Path:
    """The directory that holds ``config/`` and ``sim_assets/``."""
    override = os.environ.get("DENSEPACK_SHARE")
    if override:
        return Path(override)
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "config").is_dir() and (checkout / "sim_assets").is_dir():
        return checkout
    try:
        return Path(get_package_share_directory("densepack"))
    except (ImportError, LookupError, ValueError):
        return checkout


def config_path(name: str | Path) -> Path:
    """A file under ``config/``; absolute or existing relative paths pass through."""
    path = Path(name)
    if path.is_absolute() or path.exists():
        return path
    return share_dir() / "config" / path


def asset_path(name: str | Path) -> Path:
    path = Path(name)
    if path.is_absolute():
        return path
    return share_dir() / "sim_assets" / path
