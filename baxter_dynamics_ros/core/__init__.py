"""The core: Baxter's arm model and what computes with it, with no ROS and no message layouts.

The joints (:mod:`.joints`), the arm model and its YAML loader (:mod:`.arm_model`), the
Lagrange-Euler kernels (:mod:`.lagrange_euler`), q̈ estimators with the one zero-phase filter
(:mod:`.acceleration`), the recording and processed-recording records (:mod:`.recording`) and the
offline processing (:mod:`.processing`), the live pipeline's sample records (:mod:`.samples`), the
unmodelled effects and their spec files (:mod:`.effects`, :mod:`.effect_specs`), their
compensation (:mod:`.compensation`), the batched queries the node's services answer (:mod:`.queries`), the log-Cholesky parametrisation of pseudo-inertias
(:mod:`.log_cholesky`), the Pinocchio reference (:mod:`.pinocchio_model`), and file helpers for
YAML input and all-or-nothing output (:mod:`.yaml_files`, :mod:`.output_files`). Imports numpy,
numba, scipy and yaml only (Pinocchio inside :mod:`.pinocchio_model`'s functions).
"""
