"""3D semantic mapping with Bayesian kernel inference (S-BKI) and counting sensor models (S-CSM).

A Python rewrite of the method of BKISemanticMapping (Gan et al., "Bayesian Spatial Kernel
Smoothing for Scalable Dense Semantic Mapping", RA-L 2020), without ROS:

* :mod:`~hw4.bki.pcd`, :mod:`~hw4.bki.kitti` -- readers (labelled PCD scans, SemanticKITTI);
* :mod:`~hw4.bki.scan` -- the labelled scan every reader returns, and its checks;
* :mod:`~hw4.bki.training` -- downsampled hits and free-space samples of a scan;
* :mod:`~hw4.bki.voxelmap` -- the sparse voxel map and its incremental S-BKI / S-CSM update;
* :mod:`~hw4.bki.pipeline` -- the loop over scans; :mod:`~hw4.bki.config` -- per-dataset settings;
* :mod:`~hw4.bki.render`, :mod:`~hw4.bki.palette`, :mod:`~hw4.bki.io` -- pictures, video, files;
* :mod:`~hw4.bki.compare` -- numbers that compare two maps;
* :mod:`~hw4.bki.cli` -- ``python -m hw4 bki``.
"""
from .config import BKIConfig, load_config
from .pipeline import build_map, map_scans, new_map, scan_source, toy_paths
from .scan import Scan, validate_scan
from .training import TrainingData, training_data
from .voxelmap import FREE, OCCUPIED, UNKNOWN, MapView, VoxelMap

__all__ = ["BKIConfig", "load_config", "build_map", "map_scans", "new_map", "scan_source",
           "toy_paths", "Scan", "validate_scan", "TrainingData", "training_data", "FREE",
           "OCCUPIED", "UNKNOWN", "MapView", "VoxelMap"]
