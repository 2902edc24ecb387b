"""A motion made into a reference clip for one body: the file read and prepared for the body it builds
(:func:`~bipedsim.reference.prepare.load_source`), retargeting (``retarget(motion, model)`` ->
:class:`ReferenceClip`: qpos, qvel, foot contacts, gait events), feasibility corrections, and the
``convert`` and ``info`` commands' work.
"""

from __future__ import annotations

from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.convert import convert_bvh, format_convert_summary
from bipedsim.reference.describe import describe_bvh, format_description
from bipedsim.reference.retarget import retarget

__all__ = ["ReferenceClip", "convert_bvh", "describe_bvh", "format_convert_summary", "format_description", "retarget"]
