"""RFID space-partition localization (paper 000) and a particle filter over the same observations.

estimate: the settings and the estimate; geometry: regions, crossing arcs, orientation bounds; rogue: the
rejection of tags that cannot have been read together; particle_filter: the filter method; localizer: the
PartitionLocalizer that decodes each round and runs one of the two methods.
"""

from rfidnav_localization.partition.estimate import METHODS, LocalizationEstimate, LocalizerSettings, YawEstimate
from rfidnav_localization.partition.geometry import (
                                                     PartitionGeometry,
                                                     Region,
                                                     direction_bounds,
                                                     orientation_bounds,
                                                     partition_geometry,
                                                     read_range_of,
)
from rfidnav_localization.partition.localizer import PartitionLocalizer
from rfidnav_localization.partition.particle_filter import FilterTracker, ParticleFilter
from rfidnav_localization.partition.rogue import consistent_group

__all__ = ["METHODS", "FilterTracker", "LocalizationEstimate", "LocalizerSettings", "ParticleFilter",
           "PartitionGeometry", "PartitionLocalizer", "Region", "YawEstimate", "consistent_group", "direction_bounds",
           "orientation_bounds", "partition_geometry", "read_range_of"]
