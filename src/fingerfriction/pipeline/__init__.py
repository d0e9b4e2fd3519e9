"""The study's stages, in the order a trial flows through them.

* :mod:`.params`: the analysis options (:class:`~.params.AnalysisParams`) and the one
  definition of the pipeline's video options;
* :mod:`.trial`: one trial through the video and force stages
  (:func:`~.trial.process_trial`);
* :mod:`.plan`: what to compute and why (the resume key);
* :mod:`.selfcheck`: the consistency checks of a whole study (clock, channels, geometry,
  synchronisation);
* :mod:`.analyze`: every trial in parallel on Dask, resumable, with a run record
  (:func:`~.analyze.analyze`);
* :mod:`.fitting`: the friction model fitted to the analysed trials
  (:func:`~.fitting.fit`);
* :mod:`.validation`: the fit confirmed on held-out surfaces (leave one surface out,
  :func:`~.validation.validate_results`);
* :mod:`.finger_calibration`: the finger model calibrated to the measured contact lengths
  (:func:`~.finger_calibration.calibrate_results`).

The data these stages read and write (the manifest, the results store) is in
:mod:`fingerfriction.study`. This package namespace imports nothing: the stages are imported
from their modules, e.g. ``from fingerfriction.pipeline.analyze import analyze``.
"""
