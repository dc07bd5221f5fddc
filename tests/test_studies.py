"""hw4.studies: the options of the options study and their build times."""
from __future__ import annotations

import numpy as np
import pytest

from hw4 import studies
from hw4.errors import InputError


def test_option_kw_gives_discrete_models_their_pose_options_only():
    assert studies.option_kw(1, 16, "nearest") == {"nearest_poses": 16}
    assert studies.option_kw(3, None, "nearest") == {"nearest_poses": None}
    assert studies.option_kw(1, 16, "all") is None
    assert studies.option_kw(2, None, "all") == {"nearest_poses": None, "beams": "all"}
    assert studies.option_kw(4, 16, "nearest") == {"nearest_poses": 16, "beams": "nearest"}


def test_options_seconds_keys_match_the_options_study():
    options = (studies.OPTIONS[0], studies.OPTIONS[2])   # template; 16 poses, all beams
    secs = studies.options_seconds(grid_size=0.5, tasks=(1,), options=options, repeats=2)
    # the discrete CSM has no beams option: its "all beams" row is skipped, as in options_study
    assert set(secs) == {(1, 16, "nearest")}
    assert all(np.isfinite(v) and v > 0 for v in secs.values())
    with pytest.raises(InputError):
        studies.options_seconds(grid_size=0.5, tasks=(1,), options=options, repeats=0)
