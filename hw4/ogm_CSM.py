"""Task face: the discrete counting sensor model (Algorithm 1): Beta(alpha, beta) per cell.

Drop-in for the course template's ``ogm_CSM``::

    ogm = ogm_CSM()   # or ogm_CSM(grid_size=0.27, ...): see hw4.template.CountingSensorMap
    ogm.construct_map(robotPose, laserScan)
    ogm.build_ogm()
    ogm.map['mean'], ogm.map['variance']
"""
from .template import CountingSensorMap


class ogm_CSM(CountingSensorMap):
    """The discrete counting sensor model (Algorithm 1): Beta(alpha, beta) per cell."""

    continuous = False
    semantic = False
