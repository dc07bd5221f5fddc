"""The misspelt module name the course's ``run.py`` imports (``from ogm_continous_S_CSM import ...``)."""
from .ogm_continuous_S_CSM import ogm_continous_S_CSM, ogm_continuous_S_CSM

__all__ = ["ogm_continous_S_CSM", "ogm_continuous_S_CSM"]
