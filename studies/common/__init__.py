"""What the study scripts of ``studies/`` share.

- :mod:`~studies.common.runner`: the command line, its checks, the output folder and the end of a run;
- :mod:`~studies.common.samples`, :mod:`~studies.common.sessions`, :mod:`~studies.common.data_sources`:
  training and test samples, from sessions of the virtual RAVEN-II or from recorded data;
- :mod:`~studies.common.methods`, :mod:`~studies.common.training`, :mod:`~studies.common.evaluation`:
  the calibration methods compared, their training over seeds, their scores in the paper's units;
- :mod:`~studies.common.sweeps`: parallel sweeps (joblib, on this machine or a cluster);
- :mod:`~studies.common.discrepancy_runs`: runs of the model-discrepancy workflow;
- :mod:`~studies.common.dvrk_splits`: the dVRK recordings split into a learned and a held-out part;
- :mod:`~studies.common.reporting`, :mod:`~studies.common.plots`,
  :mod:`~studies.common.paper_numbers`: reports, figures and the paper's published numbers.
"""
