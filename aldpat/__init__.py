"""aldpat: batch airborne LiDAR processing, the ALDPAT tasks and research filters."""

__version__ = "0.1.0"
