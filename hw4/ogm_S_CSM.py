"""Task face: the semantic counting sensor model (Eqs. 8, 10): Dirichlet over 6 labels + free space.

Drop-in for the course template's ``ogm_S_CSM``::

    ogm = ogm_S_CSM()   # or ogm_S_CSM(grid_size=0.27, ...): see hw4.template.CountingSensorMap
    ogm.construct_map(robotPose, laserScan)
    ogm.build_ogm()
    ogm.map['mean'], ogm.map['variance']
"""
from .template import CountingSensorMap


class ogm_S_CSM(CountingSensorMap):
    """The semantic counting sensor model (Eqs. 8, 10): Dirichlet over 6 labels + free space."""

    continuous = False
    semantic = True
