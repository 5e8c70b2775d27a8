"""Batch and variation runs: scenarios × parameter grids × seeds on a process pool or Ray.

``spec`` expands a batch into pure ``Task``\\ s, ``tasks.run_task`` runs one,
``executors`` run many, ``results`` tabulates them. See ``docs/batch.md``.
"""
