"""Creature breeding (hierarchical evolution) and the project's sample creatures."""

from __future__ import annotations

from bipedsim.breed.evolve import (
                                      BreedError,
                                      BreedReport,
                                      MetaSkeleton,
                                      breed,
                                      crossover,
                                      floor_constraint,
                                      joint_activity,
                                      load_joint_map,
                                      mutate,
                                      survivor,
)
from bipedsim.breed.samples import horse_walk, pterosaur_flight

__all__ = ["BreedError", "BreedReport", "MetaSkeleton", "breed", "crossover", "floor_constraint", "horse_walk",
           "joint_activity", "load_joint_map", "mutate", "pterosaur_flight", "survivor"]
