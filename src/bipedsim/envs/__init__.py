"""The Gymnasium view of a body, its reference and its controller (needs ``gymnasium``: the ``env``
extra). Importing this package registers ``bipedsim/Track-v0`` (:class:`~bipedsim.envs.track.TrackEnv`):

>>> import gymnasium as gym, bipedsim.envs
>>> env = gym.make("bipedsim/Track-v0", seconds=5.0)
"""

from __future__ import annotations

import gymnasium as gym

from bipedsim.envs.settings import PushRanges, RewardWeights, TrackSettings, track_settings
from bipedsim.envs.track import TrackEnv

#: the environments this package registers, id -> entry point
ENVIRONMENTS = {"bipedsim/Track-v0": "bipedsim.envs.track:TrackEnv"}

for _id, _entry in ENVIRONMENTS.items():
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry)

__all__ = ["ENVIRONMENTS", "PushRanges", "RewardWeights", "TrackEnv", "TrackSettings", "track_settings"]
