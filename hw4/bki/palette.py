"""Class colours of the 3D maps (RGB, uint8): the toy example's and SemanticKITTI's."""
from __future__ import annotations

import numpy as np

from .kitti import CLASS_NAMES as KITTI_NAMES
from .kitti import COLORS as KITTI_COLORS

TOY_COLORS = np.array([[255, 255, 255],   # 0 free (white, never drawn as a voxel)
                       [255, 0, 0],       # 1 (the reference's rviz colours)
                       [70, 130, 180],    # 2
                       [218, 112, 214]],  # 3
                      dtype=np.uint8)
TOY_NAMES = ("free", "ground", "walls", "objects")
"""The toy scene's classes, read off its geometry: label 1 lies flat at z = 0.1 m over the whole
7 m x 10 m floor, label 2 rises to 1.7 m along the scene's outer boundary, label 3 forms the
objects standing inside it."""


KITTI_DISTINCT = {(6, 19): (6, (0, 200, 200)), (1, 5): (5, (0, 90, 90))}
"""Shades that replace SemanticKITTI's own where two classes of one figure would look alike:
``{(a, b): (class, rgb)}`` recolours ``class`` when both ``a`` and ``b`` are shown. Person
(255, 30, 30) and traffic-sign (255, 0, 0) are both pure red in the dataset's palette (CIE76
colour difference 8.9, below the ~10 at which small patches are told apart); person becomes teal,
the colour farthest from every class of sequence 04's first scans (difference >= 66, to car's
blue). Car (100, 150, 245) and other-vehicle (0, 0, 255) are two blues: CIE76 puts them 93
apart, but it overstates differences between saturated blues, and in small patches of a top view
the two read as one hue; when both are shown, other-vehicle becomes dark teal (a hue no class
uses; difference 64 to car, >= 53 to every other class but the never-drawn free). A replacement
applies only when both classes of its pair are shown, so the dataset's palette stays the default
everywhere else. Road (255, 0, 255) and parking (255, 150, 255) differ by 53, in lightness and
saturation (magenta against light pink), and keep their colours."""


def class_colors(num_class: int, present=None) -> np.ndarray:
    """(num_class, 3) uint8 RGB colours: SemanticKITTI's for 20 classes, else the toy palette
    extended with matplotlib's tab10.

    ``present`` (the classes a figure shows) applies :data:`KITTI_DISTINCT`: a class whose
    dataset colour is that of another shown class gets its documented replacement shade.
    """
    if num_class == len(KITTI_COLORS):
        out = KITTI_COLORS.copy()
        shown = set() if present is None else {int(c) for c in np.ravel(present)}
        for (a, b), (k, rgb) in KITTI_DISTINCT.items():
            if a in shown and b in shown:
                out[k] = rgb
        return out
    out = np.zeros((num_class, 3), np.uint8)
    n = min(num_class, len(TOY_COLORS))
    out[:n] = TOY_COLORS[:n]
    if num_class > n:
        from matplotlib import colormaps
        tab = (np.array(colormaps["tab10"].colors) * 255).round().astype(np.uint8)
        out[n:] = tab[np.arange(num_class - n) % 10]
    return out


def class_names(num_class: int) -> tuple:
    """Names of the classes (free first)."""
    if num_class == len(KITTI_NAMES):
        return KITTI_NAMES
    return tuple(TOY_NAMES[i] if i < len(TOY_NAMES) else f"class {i}" for i in range(num_class))
