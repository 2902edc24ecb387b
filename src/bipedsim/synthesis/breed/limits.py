"""What a breeding accepts: the spacetime parameter's range, the most frames of each parent (raised with
``BIPEDSIM_MAX_BREED_FRAMES``), and the error raised for parents that cannot be bred or a bad parameter."""

from __future__ import annotations

from bipedsim.config import limit_from_env
from bipedsim.errors import BipedsimError

#: Range of the spacetime parameter x (0 = parent A's motion, 1 = the matched motion of parent B).
X_RANGE = (0.0, 1.0)


#: Most frames of each parent (B at A's frame rate): the survivor step compares every frame of A with
#: every frame of B (20 000 frames: about 3 min at 120 fps, 11 min at 30 fps; tens of seconds). Raised
#: with ``BIPEDSIM_MAX_BREED_FRAMES``.
MAX_BREED_FRAMES = 20_000


def max_breed_frames() -> int:
    """:data:`MAX_BREED_FRAMES`, or ``BIPEDSIM_MAX_BREED_FRAMES`` where set."""
    return limit_from_env("breed_frames", MAX_BREED_FRAMES)


class BreedError(BipedsimError):
    """Parents that cannot be bred, or a bad breeding parameter."""
