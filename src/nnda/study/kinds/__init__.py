"""The registry of job kinds: what a study can run (`nnda.study.kinds.base.JobKind`).

* ``track``: a tracker over one run of a scene (`nnda.study.kinds.track`);
* ``filter``: a single-target filter over one run of a single-target scene
  (`nnda.study.kinds.filter`);
* ``reentry``: a particle filter (or Gaussian baseline) on every run of a
  ballistic re-entry setting (`nnda.study.kinds.reentry`);
* ``tbd``: a track-before-detect filter, the detector or a chain tracker on
  a block of runs of image frames (`nnda.study.kinds.tbd`);
* ``pedestrian``: a PHD filter or contact tracker on a block of runs of a
  walker scene, or the heading profiles' draws (`nnda.study.kinds.pedestrian`).

A new kind is one module defining a `JobKind` and one entry below; the
study file, the plan, keys, resume, local processes and Dask come with it.
"""

from __future__ import annotations

from nnda.study.kinds import filter, pedestrian, reentry, tbd, track
from nnda.study.kinds.base import JobKind

KINDS: dict[str, JobKind] = {k.name: k for k in (track.KIND, filter.KIND, reentry.KIND, tbd.KIND, pedestrian.KIND)}
