"""The command line: ``baxter-dynamics`` (:mod:`.main`) and one module per command (:mod:`.process`,
:mod:`.play`, :mod:`.simulate`, :mod:`.diagnose`, :mod:`.calibrate`, :mod:`.paper_experiment`),
their path check (:mod:`.paths`) and progress bar (:mod:`.progress`), the demo (``./dev demo``:
:mod:`.demo`) and the diagnosis' documentation pages (:mod:`.validation_pages`). Parses, checks
paths, calls the layers below; may import all of them.
"""
