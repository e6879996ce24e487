"""The model-based baseline: an unscented Kalman filter on the identified motor-cable-link model.

:mod:`~estimators.ukf.estimator` (the public :class:`UKFJointEstimator`), :mod:`~estimators.ukf.model`
(the identified model packed in the model layer's table layout), :mod:`~estimators.ukf.process`
(the compiled process model, built on :mod:`simulation.model.laws`), :mod:`~estimators.ukf.noise`,
:mod:`~estimators.ukf.run` (the filter over a log, with its fault handling: rejected, coasted and
re-initialised samples, :class:`~estimators.ukf.run.UKFFaultWarning`) and :mod:`~estimators.ukf._filter` (the batched
filterpy filter). Import the estimator from :mod:`estimators`.
"""
