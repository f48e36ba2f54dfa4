"""Context features: a candidate judged against its rivals, not alone.

A pair seen alone cannot tell clutter inside the gate from the target. These
five columns, appended to the IMM-extended nine
(`nnda.models.innovation.IMM_INNOVATION`), describe the pair among the
scan's other candidate pairs, from the squared Mahalanobis distances d² of
every pair (column ``mahalanobis_d2``, capped at `D2_CAP`):

* ``candidate_rank``: 0 for the track's candidate of least d², 1 for the
  next, ...;
* ``d2_margin``: d² minus the least d² of the track's *other* candidates
  (negative for the best candidate; `D2_CAP` stands in for a missing rival);
* ``n_candidates``: the track's candidate count this scan;
* ``n_rival_tracks``: how many other tracks have this contact as a candidate;
* ``rival_track_d2``: the least d² of those other tracks to this contact
  (`D2_CAP` if none): how strongly a competing track claims it.

The same function serves the neural tracker (all pairs of one scan) and the
training pairs (every target's oracle track, or a harvested run's tracks, at
one scan), in one compiled call (a few stable sorts)::

    d2 = features[:, 5]                             # (P,) from innovation_features
    ctx = context_features(track, contact, d2)      # (P, 5), columns CONTEXT_NAMES
"""

from __future__ import annotations

import numpy as np

from nnda.errors import ModelError
from nnda.filters.imm_kernels import kernel_array
from nnda.models import feature_kernels
from nnda.models.features import FeatureSet
from nnda.models.innovation import IMM_INNOVATION

CONTEXT_NAMES = ("candidate_rank", "d2_margin", "n_candidates", "n_rival_tracks", "rival_track_d2")
#: d² above this reads as "far" in every context column (a chi-square 2 value of 50 has p ~ 1e-11)
D2_CAP = 50.0
#: the column of the extended features holding d²
D2_COLUMN = IMM_INNOVATION.names.index("mahalanobis_d2")

IMM_CONTEXT = FeatureSet(
    "imm-context-14", 1, IMM_INNOVATION.names + CONTEXT_NAMES,
    "the IMM-extended nine plus the candidate's rank and d² margin among its track's candidates, the "
    "candidate count, and the number and least d² of the other tracks that have the contact as a candidate",
)


def context_features(track: np.ndarray, contact: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """Context columns (P, 5) of P pairs (module docstring).

    ``track`` (P,) and ``contact`` (P,) are integer keys (>= 0) of each
    pair's track and contact (pairs of one scan; equal keys, same track or
    contact), ``d2`` (P,) the pairs' squared Mahalanobis distances (>= 0).
    Compiled (`feature_kernels.context`): one stable sort by d², then one
    per grouping.
    """
    d2 = kernel_array(d2)
    return _into(np.empty((len(d2), len(CONTEXT_NAMES))), track, contact, d2)


def with_context(features: np.ndarray, track: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """The extended features (P, 9) of one scan's pairs with their context columns appended: (P, 14)."""
    out = np.empty((len(features), IMM_CONTEXT.size))
    out[:, :IMM_INNOVATION.size] = features
    # written into a (P, 5) array of its own, then copied: the kernel takes C-contiguous arrays alone
    out[:, IMM_INNOVATION.size:] = _into(np.empty((len(features), len(CONTEXT_NAMES))), track, contact,
                                         features[:, D2_COLUMN])
    return out


def _into(out: np.ndarray, track: np.ndarray, contact: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """``out`` (P, 5) with the context columns of the pairs written in (shapes checked)."""
    track, contact = kernel_array(track, np.int64), kernel_array(contact, np.int64)
    d2 = kernel_array(d2)  # a column of the features in `with_context`
    n = len(d2)
    if track.shape != (n,) or contact.shape != (n,):
        raise ModelError(f"context features: track, contact and d2 must have one shape (P,), got "
                         f"{track.shape}, {contact.shape}, {d2.shape}")
    feature_kernels.context(track, contact, d2, D2_CAP, out)
    return out
