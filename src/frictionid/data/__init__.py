"""Measured data: the Measurements table, the generic measurement CSV and the mapping onto axisymmetric models."""

from .measurements import (QUANTITIES, REQUIRED, UNITS_COMMENT, Measurements, map_to_axisymmetric, read_measurements,
                           write_measurements)

__all__ = ["Measurements", "QUANTITIES", "REQUIRED", "UNITS_COMMENT", "map_to_axisymmetric", "read_measurements",
           "write_measurements"]
