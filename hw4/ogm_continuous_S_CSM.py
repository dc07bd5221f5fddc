"""Task face: the continuous semantic counting sensor model (Eqs. 9, 10) with the sparse kernel.

Drop-in for the course template's ``ogm_continuous_S_CSM``::

    ogm = ogm_continuous_S_CSM()   # or ogm_continuous_S_CSM(grid_size=0.27, ...): see hw4.template.CountingSensorMap
    ogm.construct_map(robotPose, laserScan)
    ogm.build_ogm()
    ogm.map['mean'], ogm.map['variance']
"""
from .template import CountingSensorMap


class ogm_continuous_S_CSM(CountingSensorMap):
    """The continuous semantic counting sensor model (Eqs. 9, 10) with the sparse kernel."""

    continuous = True
    semantic = True


ogm_continous_S_CSM = ogm_continuous_S_CSM  # the course's run.py imports this misspelt name
