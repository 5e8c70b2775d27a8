"""The performance suite behind ``oimi bench``: each case measured beside what it is compared with.

A *reference loop* (``reference``) is a deliberately naive Python program doing a run's
per-tick task with the same libraries; *floors* (``runs``) do the real work of one part of
a case with nothing else; a *baseline* is a simpler way to get the same result that is not
a lower bound. ``suite.run_suite`` measures everything and writes the results file.
"""
