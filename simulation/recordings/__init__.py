"""Reading and writing recorded robot data: ROS bags, dataset tables, and other robots' formats."""

from simulation.recordings.bags import BagFormatError, read_bag, read_bag_folder, write_bag
from simulation.recordings.tables import TableFormatError
from simulation.recordings.limits import (
    ON_INVALID,
    VALID_COLUMN,
    ImpossibleValueError,
    ImpossibleValueWarning,
    RecordingLimits,
    find_invalid,
)
from simulation.recordings.dvrk import DvrkDataError, DvrkDataset, load_dvrk, locate_dvrk_data

__all__ = [
    "BagFormatError", "read_bag", "read_bag_folder", "write_bag",
    "TableFormatError",
    "ON_INVALID", "VALID_COLUMN", "ImpossibleValueError", "ImpossibleValueWarning", "RecordingLimits", "find_invalid",
    "DvrkDataError", "DvrkDataset", "load_dvrk", "locate_dvrk_data",
]
