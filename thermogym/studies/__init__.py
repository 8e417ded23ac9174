"""Reproductions of the reference papers' studies on the virtual rigs and real data sets.

* :mod:`~thermogym.studies.strut`: FOPTD models and the 19-node network of paper
  ``000_24627a5308ee07db.txt`` (Tables 1 and 2).
* :mod:`~thermogym.studies.spindle`: N4SID with k-fold cross-validation of paper
  ``001_6d13a2cd04f5de5e.txt`` (Tables 5 and 6) and its virtual-sensor model.
* :mod:`~thermogym.studies.realdata`: the identification methods on the real
  measured data sets of :mod:`thermogym.datasets`.

A study uses the rigs, identification, estimation and the data sets; nothing
below it imports ``studies`` (only the CLI, the demo and the benchmarks do).
"""
