"""The command line: ``baxter-dynamics`` (:mod:`.main`) and one module per command, the demo
(``./dev demo``: :mod:`.demo`) and the progress bar. Parses, checks paths, calls the layers below.
"""
