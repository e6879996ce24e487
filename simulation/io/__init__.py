"""Reading and writing recorded robot data: ROS bags, dataset tables, and other robots' formats."""

from simulation.io.bags import BagFormatError, read_bag, read_bag_folder, write_bag
from simulation.io.tables import TableFormatError
from simulation.io.dvrk import DvrkDataError, DvrkDataset, load_dvrk, locate_dvrk_data
