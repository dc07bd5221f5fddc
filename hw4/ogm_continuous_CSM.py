"""Task face: the continuous counting sensor model (Algorithm 2, Eqs. 4-6) with the sparse kernel.

Drop-in for the course template's ``ogm_continuous_CSM``::

    ogm = ogm_continuous_CSM()   # or ogm_continuous_CSM(grid_size=0.27, ...): see hw4.template.CountingSensorMap
    ogm.construct_map(robotPose, laserScan)
    ogm.build_ogm()
    ogm.map['mean'], ogm.map['variance']
"""
from .template import CountingSensorMap


class ogm_continuous_CSM(CountingSensorMap):
    """The continuous counting sensor model (Algorithm 2, Eqs. 4-6) with the sparse kernel."""

    continuous = True
    semantic = False
