"""Mapping with counting sensor models (NA 568 HW4) and 3D semantic BKI, in plain numpy."""
from .errors import InputError

__all__ = ["InputError"]
__version__ = "1.0.0"
