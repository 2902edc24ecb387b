"""Creature breeding (hierarchical evolution) and the project's sample creatures."""

from __future__ import annotations

from bipedsim.motion.samples import horse_walk, pterosaur_flight
from bipedsim.synthesis.breed.evolve import (
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
from bipedsim.synthesis.breed.files import breed_files, format_breed_summary

__all__ = ["BreedError", "BreedReport", "MetaSkeleton", "breed", "breed_files", "crossover", "floor_constraint",
           "format_breed_summary", "horse_walk", "joint_activity", "load_joint_map", "mutate", "pterosaur_flight",
           "survivor"]
