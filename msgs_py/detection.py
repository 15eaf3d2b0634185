"""A set of block poses observed at one instant: detector output or simulator ground truth."""

from __future__ import annotations

from dataclasses import dataclass, field

from msgs_py.cell import BLOCK_SIZE
from msgs_py.errors import MessageError
from msgs_py.poses import BlockPose


@dataclass(frozen=True, slots=True)
class BlockSet:
    """Blocks seen at ``stamp_ns`` (ns, the image or simulation time), poses in ``frame_id``.

    ``missing`` lists known blocks that were *not* seen in this frame and that the robot
    does not cover either (gone, or hidden by something the detector does not know of);
    ``occluded`` known blocks whose tags the robot covers in this frame, wholly or partly
    (seen or not: not judged from this frame). So a consumer can tell "gone" from "hidden".
    ``reprojection_px`` optionally holds each detected tag's reprojection error in pixels.
    """

    blocks: tuple[BlockPose, ...]
    stamp_ns: int = 0
    frame_id: str = "world"
    block_size: float = BLOCK_SIZE
    missing: tuple[int, ...] = ()
    reprojection_px: dict[int, float] = field(default_factory=dict)
    occluded: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "blocks", tuple(self.blocks))
        object.__setattr__(self, "missing", tuple(self.missing))
        object.__setattr__(self, "occluded", tuple(self.occluded))
        seen: set[int] = set()
        for k, b in enumerate(self.blocks):
            if b.id in seen:
                raise MessageError(f"blocks[{k}].id", b.id, "duplicate block id")
            seen.add(b.id)
        for k, block_id in enumerate(self.missing):
            if block_id in seen:
                raise MessageError(f"missing[{k}]", block_id, "listed both as seen and missing")
        for k, block_id in enumerate(self.occluded):
            if block_id in seen or block_id in self.missing:
                raise MessageError(f"occluded[{k}]", block_id,
                                   "listed as occluded and as seen or missing")

    @property
    def ids(self) -> list[int]:
        return [b.id for b in self.blocks]

    def by_id(self) -> dict[int, BlockPose]:
        return {b.id: b for b in self.blocks}
