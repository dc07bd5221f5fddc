"""hw4.evaluation.studies: the options of the options study and their build times."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.evaluation import studies
from hw4.core.errors import InputError


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


def test_tune_threshold_maximises_balanced_accuracy_on_the_validation_scans():
    """The chosen threshold gives the largest (occupied recall + free accuracy) / 2 of any
    threshold on the validation samples (rebuilt here from the same split), and the held-out
    test scans never enter."""
    from hw4.evaluation import evaluate as ev
    from hw4.tasks import build_map
    split = ev.intel_split()
    t, row = studies.tune_threshold(task=1, grid_size=0.27, split=split, digits=12)
    assert 0.0 <= t <= 1.0 and row["threshold"] == t
    data = ev.mapping_data(1, split)
    fit_idx, val_idx = ev.split_scans(len(data.scans), 10, 4)
    assert row["n_val"] == len(val_idx)
    fit, held = ev.subset(data, fit_idx), ev.subset(data, val_idx)
    samples = ev.held_out_samples(held, np.arange(len(held.scans)), split.samples.step,
                                  split.samples.margin)
    m = build_map(1, 0.27, data=fit)
    scores = np.unique(ev.occupancy_score(m))
    candidates = np.concatenate([[0.0, 1.0], (scores[1:] + scores[:-1]) / 2])
    best = max((lambda r: (r["occupied_recall"] + r["free_accuracy"]) / 2)(
        ev.threshold_scores(m, samples, c)) for c in candidates[:: max(1, len(candidates) // 400)])
    assert row["balanced"] >= best - 1e-12
    again = ev.threshold_scores(m, samples, t)
    assert (again["occupied_recall"] + again["free_accuracy"]) / 2 == row["balanced"]


def test_kernel_validation_chooses_the_best_validation_score_without_the_test_scans():
    """Each model's (l, sigma_0) has the best validation score of its metric (the homework's
    setting on ties), the validation scans come from the mapping scans only, and a row's scores
    are those of the map rebuilt here with that l and sigma_0."""
    from hw4.evaluation import evaluate as ev
    from hw4.tasks import build_map
    split = ev.intel_split()
    chosen, rows = studies.kernel_validation(lengths=(0.1, 0.2), sigmas=(0.1, 1.0),
                                             grid_size=0.5, split=split)
    assert set(chosen) == {2, 4} and len(rows) == 8
    for task, metric in ((2, "auc"), (4, "miou")):
        mine = [r for r in rows if r["task"] == task]
        top = max(r[metric] for r in mine)
        l, sg = chosen[task]
        pick = [r for r in mine if (r["l"], r["sigma"]) == (l, sg)][0]
        assert pick[metric] == top
        ties = [r for r in mine if r[metric] == top]
        if any((r["l"], r["sigma"]) == (0.2, 0.1) for r in ties):
            assert (l, sg) == (0.2, 0.1)
    data = ev.mapping_data(2, split)
    fit_idx, val_idx = ev.split_scans(len(data.scans), 10, 4)
    assert rows[0]["n_val"] == len(val_idx) and rows[0]["n_fit"] == len(fit_idx)
    # the validation scans are mapping scans: none of them is a held-out test scan
    assert not set(split.mapping[val_idx]) & set(split.held_out)
    held = ev.subset(data, val_idx)
    samples = ev.held_out_samples(held, np.arange(len(held.scans)), split.samples.step,
                                  split.samples.margin)
    m = build_map(2, 0.5, data=ev.subset(data, fit_idx), l=0.1, sigma=1.0)
    ref = ev.score_map(m, samples, keep_roc=False)
    row = [r for r in rows if (r["task"], r["l"], r["sigma"]) == (2, 0.1, 1.0)][0]
    assert row["auc"] == pytest.approx(ref["auc"], abs=1e-12)
