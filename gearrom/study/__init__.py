"""Operating-range studies: run-ups (speed ramps with order tracking) and tolerance scatter on dask.

* :mod:`gearrom.study.runup`: continuous speed ramp in the ROM, order tracking of the DTE.
* :mod:`gearrom.study.iso1328`: ISO 1328-1:2013 tolerances by grade.
* :mod:`gearrom.study.tolerance`: tolerance specs and sampled manufacturing deviations.
* :mod:`gearrom.study.scatter`: the per-sample task and the study runner.
* :mod:`gearrom.study.distributed`: execution on dask.distributed (LocalCluster or a scheduler).
* :mod:`gearrom.study.result`: :class:`~gearrom.study.result.ToleranceResult`.
"""
