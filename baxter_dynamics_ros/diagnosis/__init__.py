"""Diagnosis: where and why the real robot departs from the rigid-body model.

The procedure (:mod:`.procedure`: ``diagnose``) over sources read one at a time (:mod:`.sources`)
in passes of per-file work (:mod:`.passes`), with its data side (:mod:`.statistics`), fits
(:mod:`.fit`) and selection (:mod:`.selection`); where the gap lies (:mod:`.gap_analysis`); the
report and effects file (:mod:`.report`); the withheld-effect validation (:mod:`.validation`) and
the paper's experiment (:mod:`.paper_experiment`). Imports the core and the simulation only.
"""
