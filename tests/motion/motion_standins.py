"""Stand-ins for the reading quirks of two shared files that their generated stand-ins (``bvh_fixtures.py``)
do not carry, made from those stand-ins so a clone without ``../shared`` reads the same quirk:

- Bandai-Namco's root on a child: a static ``joint_Root`` at the floor above the hips, whose absolute
  position channels sit beside an OFFSET at the start pose (the stand-in's hips are the root);
- MakeHuman's walk cycle whose header's frame rate makes it faster than people walk (the stand-in's cycle
  walks at its 24 fps; at twice that rate it strides at the real cycle's 2.9 m/s).
"""

from __future__ import annotations

from pathlib import Path

from bipedsim.motion.bvh import read_bvh, write_bvh
from bipedsim.motion.reroot import add_static_root

#: the stand-in walk cycle's frame rate over its file's (24 fps): 48 fps strides at Froude 0.9
FAST_CYCLE_RATE = 2.0


def root_on_a_child(src: Path, out: Path) -> Path:
    """The clip ``src`` written to ``out`` under a static root at the origin, its old root a child whose
    OFFSET is its first frame's position and whose position channels hold the absolute position (the
    reading that adds them to the OFFSET puts the body one start position off)."""
    m = add_static_root(read_bvh(src)[0])
    offsets = m.skeleton.offsets.copy()
    offsets[1] = m.local_translations()[0, 1]
    write_bvh(m.copy(skeleton=m.skeleton.replace(offsets=offsets)), out, precision=6)
    return out


def fast_cycle(src: Path, out: Path) -> Path:
    """The clip ``src`` written to ``out`` with its Frame Time divided by :data:`FAST_CYCLE_RATE`: every
    frame kept, played that much faster."""
    m = read_bvh(src)[0]
    write_bvh(m.copy(frame_time=m.frame_time / FAST_CYCLE_RATE), out, precision=6)
    return out
